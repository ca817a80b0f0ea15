"""rcssserver's text to a player read into our messages (rcss/read.py) and our commands written as its text
(rcss/commands.py), on what rcssserver 19.0.0 really sends: the recorded sees and sense_bodies of
``tests/data/see-samples.json`` (versions 15 and 19, with the exact world of each) and the joining,
parameters and first cycles of five players of versions 8 to 19 in ``tests/data/rcss-messages.json``
(``tools/record_rcss_messages.py``). Hostile text is read to messages or skipped, never an exception."""

from __future__ import annotations

import json
import logging
import random
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from keepaway.core.objects import BALL
from keepaway.protocol import messages as m
from keepaway.protocol.landmarks import FLAGS, LINES
from keepaway.protocol.params import KernelParams, ServerParams, parameter_set
from keepaway.rcss.commands import command_text, commands_text
from keepaway.rcss.param_text import NOT_IN_RCSSSERVER, PLAYER_TYPE_PARAMS, RCSS_PARAM_NAMES
from keepaway.rcss.read import (
    MAX_TEXT_CHARS,
    Joined,
    PlayerReader,
    RcssReadError,
    read_hear,
    read_params,
    read_see,
    read_sense_body,
    server_params,
)
from keepaway.rcss.sexp import parse_one
from keepaway.server.percept_wire import see_payload, sense_body_payload
from keepaway.server.perception import SeeBuffers, SenseBodyBuffers, cone_factor, see_arena, sense_body_arena
from keepaway.server.world import new_world
from mutations import mutated_frames

DATA = Path(__file__).resolve().parent / "data"
SAMPLES = json.loads((DATA / "see-samples.json").read_text())
RECORDED = json.loads((DATA / "rcss-messages.json").read_text())
SAMPLE_PARAMS = parameter_set("current", keepaway_launch=False, visible_angle=360.0)  # the samples' server
OBSERVER = 1  # the samples' observer A 1: object 1 of a world of 2 keepers (A) and 1 taker (B)
_SEEN = re.compile(r"\(\(([^()]*)\)([^()]*)\)")


def sample_world(world: dict):
    """A world of the samples' three players and ball in the state ``world`` gives."""
    w = new_world(SAMPLE_PARAMS, 2, 1)
    w.enabled[:] = True
    w.pos[0, BALL], w.vel[0, BALL] = world["ball"][:2], world["ball"][2:4]
    for obj, key in ((1, "observer"), (2, "teammate"), (3, "opponent")):
        x, y, vx, vy, body, neck = world[key]["state"]
        w.pos[0, obj], w.vel[0, obj], w.body[0, obj], w.neck[0, obj] = (x, y), (vx, vy), body, neck
    return w


def printed(values) -> list[float]:
    """Numbers as rcssserver prints them (6 significant digits), left-out fields dropped."""
    return [float(f"{v:.6g}") for v in values if v is not None]


def named(see: m.See) -> dict[str, list[float]]:
    """A see's objects by rcssserver's names (the samples' teams A and B are our sides l and r)."""
    objects = {FLAGS[f[0]].name: printed(f[1:]) for f in see.flags}
    objects.update({LINES[line[0]].name: printed(line[1:]) for line in see.lines})
    if see.ball is not None:
        objects["b"] = printed(see.ball)
    for side, unum, *values in see.players:
        objects[f'p "{"A" if side == "l" else "B"}" {unum}'] = printed(values)
    return objects


def sample_sees():
    for run in SAMPLES["runs"]:
        for sample in run["samples"]:
            if sample["see"] is not None:
                yield run, sample


# ------------------------------------------------------------------------------------- see-samples.json


def test_every_recorded_see_reads_to_the_strings_numbers_and_to_what_our_perception_sees():
    objects = 0
    for run, sample in sample_sees():
        where = f"{run['run']} cycle {sample['cycle']}"
        see = read_see(parse_one(sample["see"]), "A", "l")
        theirs = {name: [float(v) for v in values.split()] for name, values in _SEEN.findall(sample["see"])}
        assert named(see) == theirs, where
        w = sample_world(sample["world"])
        out = SeeBuffers.empty(w.batch, w.n_objects, SAMPLE_PARAMS.kernel())
        see_arena(0, w, OBSERVER, cone_factor("normal", synch_see=run["observer"]["protocol_version"] >= 18),
                  SAMPLE_PARAMS.kernel(), out)
        ours = see_payload(out, 0, OBSERVER, w.n_keepers)
        assert {f[0] for f in see.flags} == {f[0] for f in ours["flags"]}, where
        assert {line[0] for line in see.lines} == {line[0] for line in ours["lines"]}, where
        assert [p[:2] for p in see.players] == [tuple(p[:2]) for p in ours["players"]], where
        rows = {("f", f[0]): f[1:] for f in ours["flags"]} | {("p", p[1]): p[2:] for p in ours["players"]}
        rows |= {("l", line[0]): line[1:] for line in ours["lines"]} | {("b", 0): ours["ball"]}
        read = {("f", f[0]): f[1:] for f in see.flags} | {("p", p[1]): p[2:] for p in see.players}
        read |= {("l", line[0]): line[1:] for line in see.lines}
        assert (see.ball is None) == (ours["ball"] is None), where
        if see.ball is not None:
            read[("b", 0)] = see.ball
        for key, values in read.items():
            # rcssserver leaves out a far object's changes at random: compare what both carry
            n = min(len(printed(values)), len(printed(rows[key])))
            assert n >= 2 and printed(values)[:n] == printed(rows[key])[:n], f"{where} {key}"
            objects += 1
    assert objects == 4657  # every object of every see string (tests/test_perception.py)


def test_every_recorded_sense_body_reads_to_its_numbers_and_to_our_perception():
    for run in SAMPLES["runs"]:
        for sample in run["samples"]:
            body = read_sense_body(parse_one(sample["sense_body"]))
            w = sample_world(sample["world_at_cycle"])
            out = SenseBodyBuffers.empty(1, w.n_objects - 1)
            sense_body_arena(0, w, OBSERVER, out)
            ours = sense_body_payload(out, 0, OBSERVER, "high", "normal")
            assert body.cycle == sample["cycle"]
            assert (list(body.view_mode), body.speed[1], body.head_angle) == (
                ours["view_mode"], ours["speed"][1], ours["head_angle"])
            assert body.speed[0] == pytest.approx(ours["speed"][0])
            assert body.stamina == (8000.0, 1.0, 130600.0) and body.collision == ()
            assert body.counts == dict.fromkeys(m.COMMAND_COUNTS, 0)


# ------------------------------------------------------------------------------ rcss-messages.json


def read_all(player: dict, caplog) -> list:
    """Everything one recorded player received, read by one PlayerReader; no datagram skipped."""
    unum = 4 if "(reconnect keepers 4)" in player["sent"] else None
    reader = PlayerReader(player["team"], unum)
    with caplog.at_level(logging.WARNING, logger="keepaway.rcss"):
        found = [item for text in player["received"] for item in reader.read(text + "\0")]
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    return found


def of_type(found: list, cls: type) -> list:
    return [item for item in found if isinstance(item, cls)]


@pytest.mark.parametrize("player", RECORDED["players"], ids=lambda p: f"{p['team']}-v{p['version']}")
def test_a_recorded_player_joins_with_rcssservers_parameters_as_our_current_set(player, caplog):
    found = read_all(player, caplog)
    joined = of_type(found, Joined)
    side, unum = ("l", RECORDED["players"].index(player) + 1) if player["team"] == "keepers" else ("r", 1)
    assert joined[0] == Joined(side, unum, "before_kick_off")
    assert len(joined) == len(of_type(found, m.InitOk)) == 1  # the reconnected player: only its first answer
    init_ok = of_type(found, m.InitOk)[0]
    assert (init_ok.side, init_ok.unum, init_ok.team, init_ok.config) == (side, unum, player["team"], {"mode": "sync"})
    # rcssserver 19's defaults with keepaway.sh's launch settings are our CURRENT set, name for name
    assert ServerParams.from_dict(init_ok.params) == parameter_set("current")


def test_every_parameter_we_read_is_in_rcssservers_messages():
    received = RECORDED["players"][0]["received"]
    server = read_params(parse_one(next(t for t in received if t.startswith("(server_param"))))
    player_type = read_params(parse_one(next(t for t in received if t.startswith("(player_type (id 0)"))))
    for name in KernelParams._fields:
        if name in PLAYER_TYPE_PARAMS:
            assert name in player_type, name
        elif name not in NOT_IN_RCSSSERVER:
            assert RCSS_PARAM_NAMES.get(name, name) in server, name


def test_the_recorded_percepts_read_as_the_players_acted(caplog):
    keeper, *others, taker = [read_all(p, caplog) for p in RECORDED["players"]]
    bodies = {b.cycle: b for b in of_type(keeper, m.SenseBody)}
    # keeper 1's script: turn at 1, dash at 2, say and turn_neck at 3, change_view at 4 (counted a cycle later)
    assert [bodies[c].counts["turn"] for c in (1, 2)] == [0, 1]
    assert [bodies[c].counts["dash"] for c in (2, 3)] == [0, 1]
    assert bodies[4].counts["say"] == bodies[4].counts["turn_neck"] == 1 and bodies[4].head_angle == 29
    assert bodies[5].view_mode == ("high", "wide") and bodies[5].counts["change_view"] == 1
    assert bodies[3].speed[0] > 0
    hears = {(h.sender, h.message) for h in of_type(keeper, m.Hear)}
    assert {("referee", "play_on"), ("self", "hello"), ("opp", "abc")} <= hears
    for player in others:
        heard = [h for h in of_type(player, m.Hear) if h.sender == "our"]
        assert [(h.unum, h.message) for h in heard] == [(1, "hello")] and -180 <= heard[0].direction <= 180
    assert {("self", "abc"), ("opp", "hello")} <= {(h.sender, h.message) for h in of_type(taker, m.Hear)}
    for found in (keeper, *others, taker):
        assert of_type(found, m.Think) and all(t.cycle in bodies for t in of_type(found, m.Think))
    seen = {(p[0], p[1]) for see in of_type(keeper, m.See) for p in see.players}
    assert {("l", 2), ("l", 3), ("l", 4), ("r", 1)} <= seen
    assert all(see.flags for see in of_type(taker, m.See))


@pytest.mark.parametrize("refusal", RECORDED["refusals"], ids=lambda r: r["sent"])
def test_a_refused_join_reads_as_an_error_with_rcssservers_reason(refusal):
    (error,) = PlayerReader("keepers").read(refusal["received"])
    assert isinstance(error, m.Error) and refusal["received"] == f"(error {error.code})"


# ------------------------------------------------------------------------------------- the other forms


@pytest.mark.parametrize("text, expected", [
    ("(hear 54 referee training Keepaway 1)", m.Hear(cycle=54, sender="referee", message="training Keepaway 1")),
    ('(hear 7 -30 our 2 "1aaaa18aa1")', m.Hear(cycle=7, sender="our", direction=-30, unum=2, message="1aaaa18aa1")),
    ('(hear 7 online_coach_left "go")', m.Hear(cycle=7, sender="coach", message="go")),
    ("(hear 7 our 2)", None),  # the short forms carry no message
    ("(hear 7 opp)", None),
    ("(hear 7 online_coach_right (info (0 (true) (do our {2} (pos (pt 1 2))))))", None),  # CLang
])
def test_hear_reads_every_sender_rcssserver_names(text, expected):
    assert read_hear(parse_one(text)) == expected


def test_see_reads_the_anonymous_and_marked_players_and_leaves_out_low_quality_objects():
    see = read_see(parse_one('(see 3 ((F) 1.2 40) ((f c) 3 -10 0.1 2) ((B) 0.9 -170) ((P) 2.5 100) ((p) 30.1 5) '
                             '((p "takers") 24.5 -12 20) ((p "keepers" 2) 8.2 -45 0.16 -1.2 30 30 k) '
                             '((p "takers" 1 goalie) 9 10 0 0 -90 -90 45 t) ((f r t) 12) ((l b) 40))'),
                   "keepers", "l")
    assert see.flags == ((None, 1.2, 40, None, None), (0, 3.0, -10, 0.1, 2.0))
    assert see.ball == (0.9, -170, None, None) and see.lines == ()
    unseen = (None,) * 4  # changes and facing
    assert see.players == ((None, None, 2.5, 100, *unseen), (None, None, 30.1, 5, *unseen),
                           ("r", None, 24.5, -12, *unseen), ("l", 2, 8.2, -45, 0.16, -1.2, 30, 30),
                           ("r", 1, 9.0, 10, 0.0, 0.0, -90, -90))


def test_a_sense_body_before_version_13_has_no_capacity():
    body = read_sense_body(parse_one("(sense_body 9 (view_mode low narrow) (stamina 3999.5 0.9) (speed 0.33 -12) "
                                     "(head_angle -45) (kick 2) (dash 5) (turn 1) (say 0) "
                                     "(collision (ball) (player)))"))
    assert (body.view_mode, body.stamina, body.speed, body.head_angle) == (("low", "narrow"), (3999.5, 0.9, -1.0),
                                                                          (0.33, -12), -45)
    assert body.counts["dash"] == 5 and body.counts["turn_neck"] == 0 and body.collision == ("ball", "player")


def test_a_value_out_of_our_tables_range_is_refused():
    with pytest.raises(RcssReadError, match="ball_decay"):
        server_params({"ball_decay": "1.5"}, {})
    assert server_params({"ball_decay": "0.9"}, {"player_decay": "0.5"}).ball_decay == 0.9


# ------------------------------------------------------------------------------------------------ hostile


def read_quietly(reader: PlayerReader, text: str) -> list:
    """What ``reader`` takes of ``text``: a list of messages (possibly empty), whatever the text."""
    found = reader.read(text)
    assert all(isinstance(item, (Joined, m.Message)) for item in found)
    return found


def joined_reader() -> PlayerReader:
    reader = PlayerReader("keepers")
    for text in RECORDED["players"][0]["received"][:4]:  # init, server_param, player_param, player_type 0
        reader.read(text)
    assert reader.ready
    return reader


def test_corrupted_rcssserver_text_is_read_or_skipped_never_raised():
    reader = joined_reader()
    texts = [t.encode("latin-1") for p in RECORDED["players"] for t in p["received"]]
    for data in mutated_frames(texts, count=3000, most_changes=6, seed=11):
        read_quietly(reader, data.decode("latin-1"))


@pytest.mark.parametrize("text", [
    "(" * 100_000, ")", "(see", '(see 1 ((p "keepers) 1 2))', "(sense_body 1 (kick))", "(see 1 ((f c) nan 0))",
    "(see 1 ((f c) inf 0))", "(see 1 ((f c) 1e999 0))", f"(see {'9' * 5000} )", "(see 1 ((b) 1 2 3))",
    "(sense_body 1 (view_mode high normal) (stamina -1 1) (speed 0 0) (head_angle 0))", "(think extra)",
    "(hear 1 99999 our 1 \"x\")", "(hear 1 0 our 99 \"x\")", "(init l 1 before_kick_off)", "(init x 1 play_on)",
    "(server_param (ball_decay))", "(player_type (id 0) (ball_decay 7))", "(error)", "(error (x))", "\0" * 10,
    "x" * (MAX_TEXT_CHARS + 1), "(see 1 " + "((p) 1 2)" * 30 + ")", "(see 1 " + "((f c) 1 2)" * 300 + ")",
])
def test_hostile_text_is_read_or_skipped(text):
    read_quietly(joined_reader(), text)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=st.sampled_from('()" \0-.0123456789abcdefghijklmnopqrstuvwxyz'), max_size=200))
def test_random_text_is_read_or_skipped(text):
    read_quietly(joined_reader(), text)


# ------------------------------------------------------------------------------------------------ commands


def test_commands_are_rcssservers_text():
    commands = (m.AtomicCommand("dash", (100.0, 0.0)), m.AtomicCommand("turn_neck", (-19.0,)),
                m.AtomicCommand("say", ("1aaaa18aa1",)), m.AtomicCommand("change_view", ("wide", "high")),
                m.AtomicCommand("kick", (55.5, -0.1)), m.AtomicCommand("done"))
    assert commands_text(commands) == '(dash 100 0)(turn_neck -19)(say "1aaaa18aa1")(change_view wide high)' \
                                      "(kick 55.5 -0.1)(done)"


def test_command_numbers_read_back_exactly():
    rng = random.Random(3)
    for value in [rng.uniform(-180, 180) for _ in range(1000)] + [1e-05, -2.5e-12, 1e300, 2.0**60, -0.0]:
        text = command_text(m.AtomicCommand("turn", (value,)))
        assert re.fullmatch(r"\(turn [-+0-9.e]+\)", text) and float(text[6:-1]) == value
