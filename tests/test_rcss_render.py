"""rcss/render.py against rcssserver 19.0.0's own text: every recorded message, rendered by us from the same
world, equals rcssserver's string byte for byte.

The recordings: ``tests/data/see-samples.json`` (protocol versions 15 and 19: the sees and sense_bodies
of a standing and a moving observer) and ``tests/data/rcss-text-samples.json`` (tools/record_rcss_text.py:
the init reply, the parameter messages and the reconnect reply of versions 8 to 19 under our two parameter
sets; the sees, sense_bodies and hears of versions 8, 12, 13, 14 and 19 in three scenarios, with the exact
world state of every cycle and every client's commands; rcssserver's answers to refused inits).

Our messages are computed from the recorded state by the server's own code (``server.perception``). Which
objects lose their changes, number or team beyond the far lengths is random, in rcssserver and in our
perception alike: our see is computed with nothing lost, then loses what the recorded see lost, each loss
checked to be one our perception can make at that distance. Every number, name and the order are ours.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from keepaway.core.objects import BALL
from keepaway.protocol import messages as m
from keepaway.protocol.codec import encode
from keepaway.protocol.landmarks import FLAGS, LINES, to_wire
from keepaway.protocol.params import parameter_set
from keepaway.rcss.param_text import PLAYER_PARAMS, SERVER_PARAMS, our_server_params
from keepaway.rcss.render import (
    SUPPORTED_VERSIONS,
    TextView,
    error,
    hear,
    init_messages,
    parameter_messages,
    reconnect_messages,
    see,
    sense_body,
    supported,
    think,
)
from keepaway.rcss.see_text import MAX_SEE_BYTES, NOT_WRITTEN, SeeNames, write_see
from keepaway.rcss.sexp import parse_one, unquote
from keepaway.server.arena import REFEREE_EPISODE_MESSAGE
from keepaway.server.percept_wire import COUNT_NAMES, see_payload, sense_body_payload
from keepaway.server.perception import (
    SeeBuffers,
    SenseBodyBuffers,
    cone_factor,
    hear_direction,
    see_arena,
    sense_body_arena,
)
from keepaway.server.world import World, new_world

DATA = Path(__file__).resolve().parent / "data"
FLAG_NAMES = tuple(flag.name for flag in FLAGS)
LINE_NAMES = tuple(line.name for line in LINES)
TEAMS = ("keepers", "takers")
RCSS_DEFAULTS = parameter_set("current", keepaway_launch=False)  # rcssserver 19.0.0's defaults
LOSSLESS = {"unum_far_length": 1000.0, "unum_too_far_length": 1001.0, "team_far_length": 1000.0,
            "team_too_far_length": 1001.0}
OBSERVER = 1  # keepers 1; keepers 2 is object 2, takers 1 object 3
# What a v18+ player_type says and ours does not: rcssserver gives v18+ clients type 0's far lengths of the
# team, the longest distance on the pitch (so they never lose a player's team there), where our perception
# loses it beyond team_far_length for every client (ServerParams.team_far_length, team_too_far_length).
TEAM_FAR_LENGTHS = ("(team_far_length 125.096)(team_too_far_length 125.096)",
                    "(team_far_length 40)(team_too_far_length 60)")
# A goal too close to name: rcssserver writes (G), our see's row does not say which landmark it is.
CLOSE_GOAL = ("((G) ", "((F) ")


@cache
def text_samples() -> dict:
    return json.loads((DATA / "rcss-text-samples.json").read_text())


@cache
def see_samples() -> dict:
    return json.loads((DATA / "see-samples.json").read_text())


def view(version: float, teams: tuple[str, str] = TEAMS) -> TextView:
    return TextView(version, "l", teams, FLAG_NAMES, LINE_NAMES, RCSS_DEFAULTS.unum_far_length,
                    RCSS_DEFAULTS.team_far_length)


def world_of(ball: list[float], players: dict[int, list[float]]) -> World:
    """A world of keepers 1 and 2 and takers 1 (objects 1, 2, 3) in the given states: ``[x, y, vx, vy,
    body, neck]``, optionally followed by stamina, effort, recovery and capacity."""
    w = new_world(RCSS_DEFAULTS, 2, 1)
    w.enabled[:] = True
    w.pos[0, BALL], w.vel[0, BALL] = ball[:2], ball[2:4]
    for obj, state in players.items():
        w.pos[0, obj], w.vel[0, obj] = state[:2], state[2:4]
        w.body[0, obj], w.neck[0, obj] = state[4], state[5]
        if len(state) > 6:
            w.stamina[0, obj], w.effort[0, obj], w.recovery[0, obj], w.capacity[0, obj] = state[6:10]
    return w


def recorded_world(world: dict) -> World:
    """The world of a rcss-text-samples state (players by "side unum")."""
    objects = {"l 1": 1, "l 2": 2, "r 1": 3}
    return world_of(world["ball"], {objects[name]: state for name, state in world["players"].items()})


def lossless_see(w: World, cycle: int, factor: float, visible_angle: float) -> m.See:
    """Our see of the observer with no identity lost at any distance."""
    params = RCSS_DEFAULTS.replace(visible_angle=visible_angle, **LOSSLESS)
    out = SeeBuffers.empty(1, w.n_objects, params.kernel())
    see_arena(0, w, OBSERVER, factor, params.kernel(), out)
    return m.See(cycle=cycle, **see_payload(out, 0, OBSERVER, w.n_keepers))


def _far(dist: float, lost: bool, far: float, too_far: float, what: str) -> None:
    """A loss our perception can make: only beyond ``far``; what it keeps, only below ``too_far``."""
    if lost:
        assert dist > far, f"{what} lost at {dist} m, within {far} m"
    else:
        assert dist < too_far, f"{what} kept at {dist} m, beyond {too_far} m"


def as_recorded(ours: m.See, text: str) -> m.See:
    """``ours`` with the random losses of rcssserver's ``text``: the flags, the ball and the players of
    both, in order, paired; where rcssserver left out changes, a number or a team, ours does too."""
    p = RCSS_DEFAULTS
    items = parse_one(text)[2:]
    kinds = {"flags": [i for i in items if i[0][0] in "fgFG"], "ball": [i for i in items if i[0][0] in "bB"],
             "players": [i for i in items if i[0][0] in "pP"]}
    assert (len(kinds["flags"]), len(kinds["ball"]), len(kinds["players"])) == \
        (len(ours.flags), ours.ball is not None, len(ours.players)), "other objects seen"
    flags = []
    for row, item in zip(ours.flags, kinds["flags"]):
        if row[0] is not None:
            _far(row[1], len(item) == 3, p.unum_far_length, p.unum_too_far_length, f"flag {FLAG_NAMES[row[0]]}")
            row = row if len(item) > 3 else (*row[:3], None, None)
        flags.append(row)
    ball = ours.ball
    if ball is not None and kinds["ball"][0][0] == ["b"]:
        _far(ball[0], len(kinds["ball"][0]) == 3, p.unum_far_length, p.unum_too_far_length, "ball")
        ball = ball if len(kinds["ball"][0]) > 3 else (*ball[:2], None, None)
    players = []
    for row, item in zip(ours.players, kinds["players"]):
        name = item[0]
        if name[0] == "p":
            _far(row[2], len(name) < 3, p.unum_far_length, p.unum_too_far_length, "a player's number")
            _far(row[2], len(name) < 2, p.team_far_length, p.team_too_far_length, "a player's team")
            if len(name) < 3:
                row = (row[0] if len(name) == 2 else None, None, *row[2:4], None, None, None, None)
        players.append(row)
    return m.See(cycle=ours.cycle, flags=tuple(flags), lines=ours.lines, ball=ball, players=tuple(players))


def our_sense_body(w: World, cycle: int, view_mode: tuple[str, str], counts: Counter) -> m.SenseBody:
    w.counts[0, OBSERVER] = [counts[name] for name in COUNT_NAMES]
    out = SenseBodyBuffers.empty(1, w.n_objects)
    sense_body_arena(0, w, OBSERVER, out)
    return m.SenseBody(cycle=cycle, **sense_body_payload(out, 0, OBSERVER, *view_mode))


# -- versions, init and the parameter messages ------------------------------------------------------------


def test_versions_8_to_19_are_rendered_and_others_refused():
    assert [v for v in range(1, 25) if supported(v)] == list(SUPPORTED_VERSIONS) == list(range(8, 20))
    assert supported(12.5) and not supported(7.99)
    for version in (7, 20):
        with pytest.raises(ValueError, match="not rendered"):
            view(version)
    assert error(m.Error(cycle=0, code="bad_version", message="")) == text_samples()["errors"]["bad_version"]


@pytest.mark.parametrize("run", text_samples()["init_runs"], ids=lambda r: f"v{r['version']}-{r['parameter_set']}")
def test_init_reply_and_parameter_messages_are_rcssservers(run):
    """Under the same parameters (rcssserver started with our set in its names and one player type), all a
    player gets at its init and at a reconnect is rcssserver's, but for the team far lengths of a v18+
    player_type (TEAM_FAR_LENGTHS); the settings that are not ours come from the recording."""
    params = parameter_set(run["parameter_set"])
    ours_by_rcss_name = our_server_params(params)
    settings = {name: value for name, value in run["settings"].items()
                if "::" not in name and name not in ours_by_rcss_name}
    expected_init = list(run["messages"])
    if run["version"] >= 18:
        assert TEAM_FAR_LENGTHS[0] in expected_init[3]
        expected_init[3] = expected_init[3].replace(*TEAM_FAR_LENGTHS)
    expected_reconnect = [run["reconnect_reply"], *expected_init[1:4]]
    text_view = view(run["version"])
    assert init_messages(params, text_view, 1, "before_kick_off", settings) == expected_init
    assert reconnect_messages(params, text_view, "before_kick_off", settings) == expected_reconnect


@pytest.mark.parametrize("run", text_samples()["init_runs"], ids=lambda r: f"v{r['version']}-{r['parameter_set']}")
def test_first_sense_body_of_every_version_is_rcssservers(run):
    """A player as it joined (at rest, full stamina, no command yet) under our parameter set: every
    version's sense_body layout, and the stamina capacity of a set without one (CLASSIC's -1)."""
    w = new_world(parameter_set(run["parameter_set"]), 2, 1)
    w.enabled[:] = True
    assert sense_body(our_sense_body(w, 0, ("high", "normal"), Counter()), view(run["version"])) == run["sense_body"]


# The parameters the keepaway-0.6 players read (SenseHandler::analyzeServerParamMessage and
# analyzePlayerParamMessage, keepaway-0.6 player/SenseHandler.cc), each found as it finds it: the first
# "name " in the message, its value up to the next ")".
CPP_SERVER_PARAMS = (
    "goal_width player_size player_decay player_rand player_weight player_speed_max player_accel_max stamina_max "
    "stamina_inc_max recover_dec_thr recover_min recover_dec effort_dec_thr effort_min effort_dec effort_inc_thr "
    "effort_inc kick_rand ball_size ball_decay ball_rand ball_weight ball_speed_max ball_accel_max dash_power_rate "
    "kick_power_rate kickable_margin catch_probability catchable_area_l catchable_area_w goalie_max_moves maxpower "
    "minpower maxmoment minmoment maxneckmoment minneckmoment maxneckang minneckang visible_angle visible_distance "
    "audio_cut_dist quantize_step quantize_step_l ckick_margin wind_dir wind_force wind_rand wind_random "
    "inertia_moment half_time drop_ball_time port coach_port olcoach_port say_coach_cnt_max say_coach_msg_size "
    "simulator_step send_step recv_step sense_body_step say_msg_size clang_win_size clang_define_win clang_meta_win "
    "clang_advice_win clang_info_win clang_mess_delay clang_mess_per_cycle hear_max hear_inc hear_decay "
    "catch_ban_cycle send_vi_step use_offside offside_active_area_size forbid_kick_off_offside verbose "
    "offside_kick_margin slow_down_factor synch_mode fullstate_l fullstate_r pen_dist_x pen_max_goalie_dist_x "
    "pen_allow_mult_kicks tackle_dist tackle_back_dist tackle_width tackle_cycles tackle_power_rate tackle_exponent "
    "keepaway_length keepaway_width").split()
CPP_PLAYER_PARAMS = (
    "player_types subs_max player_speed_max_delta_min player_speed_max_delta_max stamina_inc_max_delta_factor "
    "player_decay_delta_min player_decay_delta_max inertia_moment_delta_factor dash_power_rate_delta_min "
    "dash_power_rate_delta_max player_size_delta_factor kickable_margin_delta_min kickable_margin_delta_max "
    "kick_rand_delta_factor extra_stamina_delta_min extra_stamina_delta_max effort_max_delta_factor "
    "effort_min_delta_factor new_dash_power_rate_delta_min new_dash_power_rate_delta_max "
    "new_stamina_inc_max_delta_factor").split()


def cpp_read(message: str, name: str) -> str | None:
    """``SenseHandler::readServerParam``: the text after the first "name " up to the next ")"."""
    at = message.find(name + " ")
    return None if at < 0 else re.match(r"[^)]*", message[at + len(name) + 1:]).group(0)


@pytest.mark.parametrize("set_name", ["classic", "current"])
def test_the_keepaway_players_read_every_parameter_they_need_as_from_rcssserver(set_name):
    """Version 12 (the keepaway-0.6 players' default): every parameter they look for is in our messages
    and reads as in rcssserver's, and its player_type gives their reader the id and our 11 values in order."""
    run = next(r for r in text_samples()["init_runs"] if r["version"] == 12 and r["parameter_set"] == set_name)
    params = parameter_set(set_name)
    settings = {name: value for name, value in run["settings"].items()
                if "::" not in name and name not in our_server_params(params)}
    server_param, player_param, player_type = parameter_messages(params, view(12), settings)
    for message, recorded, names in ((server_param, run["messages"][1], CPP_SERVER_PARAMS),
                                     (player_param, run["messages"][2], CPP_PLAYER_PARAMS)):
        for name in names:
            assert cpp_read(message, name) is not None, name
            assert cpp_read(message, name) == cpp_read(recorded, name), name
    numbers = [float(v) for v in re.findall(r"-?[0-9.]+(?:e[-+][0-9]+)?", player_type)]
    assert numbers[:12] == [0.0, params.player_speed_max, params.stamina_inc_max, params.player_decay,
                            params.inertia_moment, params.dash_power_rate, params.player_size, params.kickable_margin,
                            params.kick_rand, params.extra_stamina, params.effort_max, params.effort_min]


def test_parameter_tables_are_in_name_order_and_ours_are_rcssservers():
    for table in (SERVER_PARAMS, PLAYER_PARAMS):
        names = [name for name, _, _ in table]
        assert names == sorted(names) and len(set(names)) == len(names)
    assert set(our_server_params(parameter_set("classic"))) <= {name for name, _, _ in SERVER_PARAMS}
    with pytest.raises(ValueError, match="from the parameter set"):
        parameter_messages(parameter_set("classic"), view(12), {"visible_angle": 90})
    with pytest.raises(ValueError, match="no server parameter"):
        parameter_messages(parameter_set("classic"), view(12), {"no_such_name": 1})
    with pytest.raises(ValueError, match="is an integer"):
        parameter_messages(parameter_set("classic"), view(12), {"port": 6000.5})


def test_refused_inits_are_answered_as_rcssserver_answers_them():
    for code, text in text_samples()["errors"].items():
        assert error(m.Error(cycle=3, code=code, message="why")) == text
    assert error(m.Error(cycle=3, code="dropped", message="say too long")) is None
    assert think() == "(think)"


# -- see and sense_body of see-samples.json (versions 15 and 19) -------------------------------------------


def see_sample_cases():
    for run in see_samples()["runs"]:
        for sample in run["samples"]:
            yield pytest.param(run, sample, id=f"{run['run']}-{sample['cycle']}")


def kernel_see(msg: m.See, text_view: TextView) -> str:
    """``msg`` as the front writes our server's frame of it: by the see kernel (``rcss.see_text``)."""
    frame = encode(msg)
    out = np.empty(MAX_SEE_BYTES, np.uint8)
    n = write_see(frame, len(frame), SeeNames.of(*text_view.names), out)
    assert n != NOT_WRITTEN
    return out[:n].tobytes().decode("latin-1")


def see_sample_world(world: dict) -> World:
    return world_of(world["ball"], {obj: world[key]["state"]
                                    for obj, key in ((1, "observer"), (2, "teammate"), (3, "opponent"))})


@pytest.mark.parametrize("run, sample", list(see_sample_cases()))
def test_see_samples_see_and_sense_body_are_rcssservers(run, sample):
    version = run["observer"]["protocol_version"]
    text_view = view(version, ("A", "B"))
    if sample["see"] is not None:
        factor = cone_factor("normal", synch_see=version >= 18)
        ours = lossless_see(see_sample_world(sample["world"]), sample["cycle"], factor, 360.0)
        assert see(as_recorded(ours, sample["see"]), text_view) == sample["see"]
        assert kernel_see(as_recorded(ours, sample["see"]), text_view) == sample["see"]
    ours = our_sense_body(see_sample_world(sample["world_at_cycle"]), sample["cycle"], ("high", "normal"), Counter())
    assert sense_body(ours, text_view) == sample["sense_body"]


# -- see, sense_body and hear of rcss-text-samples.json (versions 8, 12, 13, 14, 19) ------------------------


def commands_of(run: dict, client: str) -> dict[int, list[list]]:
    return {int(cycle): [parse_one(c) for c in commands] for cycle, commands in run["commands"][client].items()}


def view_widths(run: dict) -> list[str]:
    """The observer's view width in each cycle: changed by its change_view of the cycle before."""
    widths, width = [], "normal"
    changes = commands_of(run, "observer")
    for window in run["windows"]:
        widths.append(width)
        width = next((c[1] for c in changes.get(window["cycle"], []) if c[0] == "change_view"), width)
    return widths


def shows_its_cycle(run: dict, window: dict, text: str) -> bool:
    """Whether a see stamped T shows the state recorded for cycle T. Not if it arrived after the trainer's
    moves or the observer's change_view of T's window (it may show them), nor if stamped 0: before the
    kick-off rcssserver steps without advancing the time (src/stadium.cpp, Stadium::step), so sees stamped
    0 come from several states (a right player's body turns from 180 to 0 degrees among them)."""
    cycle = int(text.split()[1])
    return cycle > 0 and (window["cycle"] == cycle or not run["windows"][cycle]["changed_in_window"])


def play_cases(kind: str):
    for run in text_samples()["play_runs"]:
        for window in run["windows"]:
            for text in window["observer"]:
                if text.startswith(f"({kind} ") and (kind != "see" or shows_its_cycle(run, window, text)):
                    yield pytest.param(run, window, text, id=f"{run['scenario']}-v{run['version']}-{text[:12]}")


def test_the_recordings_hold_every_kind_of_see_object():
    assert len(list(play_cases("see"))) >= 100
    sees = " ".join(case.values[2] for case in play_cases("see"))
    for name in ("((F) ", "((G) ", "((b) ", "((B) ", '((p "keepers" 2) ', '((p "takers") ', "((p) ", "((P) ", "((l "):
        assert name in sees, name
    assert re.search(r"\(\(b\) [0-9.]+ -?[0-9]+\)", sees), "a far ball without its changes"


@pytest.mark.parametrize("run, window, text", list(play_cases("see")))
def test_recorded_sees_are_rcssservers(run, window, text):
    """Each see that shows the state of its cycle (:func:`shows_its_cycle`), from our see of that state."""
    cycle = int(text.split()[1])
    windows = run["windows"]
    version = run["version"]
    width = view_widths(run)[cycle]
    factor = cone_factor(width, synch_see=version >= 18)
    ours = lossless_see(recorded_world(windows[cycle]["world"]), cycle, factor,
                        float(run["settings"].get("visible_angle", RCSS_DEFAULTS.visible_angle)))
    expected = text.replace(*CLOSE_GOAL)
    assert see(as_recorded(ours, text), view(version)) == expected
    assert kernel_see(as_recorded(ours, text), view(version)) == expected  # the front's way (rcss.see_text)


@pytest.mark.parametrize("run, window, text", list(play_cases("sense_body")))
def test_recorded_sense_bodies_are_rcssservers(run, window, text):
    """The exact state of the cycle, the observer's commands of the cycles before as its counts."""
    cycle = window["cycle"]
    counts = Counter(c[0] for t, commands in commands_of(run, "observer").items() if t < cycle for c in commands)
    ours = our_sense_body(recorded_world(window["world"]), cycle, ("high", view_widths(run)[cycle]), counts)
    assert sense_body(ours, view(run["version"])) == text


def our_hears(run: dict) -> list[m.Hear]:
    """What our server makes the observer hear of the recorded commands (docs/rules.md §5.5): the referee
    at a play-mode change and when the ball leaves the Keepaway region (heard in the cycle after the step
    it left in), the coach's freeform text in the cycle it said it, says in the next cycle with the
    direction from the observer's body then."""
    hears = []
    region = (float(run["settings"].get("keepaway_length", 20)), float(run["settings"].get("keepaway_width", 20)))
    worlds = [recorded_world(w["world"]) for w in run["windows"]]
    for cycle, commands in commands_of(run, "trainer").items():
        for command in commands:
            if command[0] == "change_mode":
                hears.append(m.Hear(cycle=cycle, sender="referee", message=command[1]))
            elif command[:2] == ["move", ["ball"]] and run["settings"].get("keepaway") and any(
                    abs(float(v)) >= side / 2 for v, side in zip(command[2:4], region)):
                hears.append(m.Hear(cycle=cycle + 1, sender="referee", message=REFEREE_EPISODE_MESSAGE))
    for cycle, commands in commands_of(run, "coach").items():
        hears += [m.Hear(cycle=cycle, sender="coach", message=unquote(c[1][1])) for c in commands]
    for client, sender, speaker in (("observer", "self", OBSERVER), ("teammate", "our", 2), ("opponent", "opp", 3)):
        for cycle, commands in commands_of(run, client).items():
            for command in commands:
                if command[0] != "say":
                    continue
                direction = None if sender == "self" else hear_direction(0, worlds[cycle + 1], OBSERVER, speaker)
                hears.append(m.Hear(cycle=cycle + 1, sender=sender, direction=direction,
                                    unum=speaker if sender == "our" else None, message=" ".join(command[1:])))
    return hears


@pytest.mark.parametrize("run", text_samples()["play_runs"], ids=lambda r: f"{r['scenario']}-v{r['version']}")
def test_recorded_hears_are_rcssservers(run):
    recorded = [t for w in run["windows"] for t in w["observer"] if t.startswith("(hear ")]
    assert recorded
    ours = [hear(msg, view(run["version"])) for msg in our_hears(run)]
    assert sorted(ours) == sorted(recorded)


# -- what a text client cannot be told -----------------------------------------------------------------------


def test_coach_advice_reaches_a_text_client_only_as_text_without_quotes():
    text_view = view(12)
    assert hear(m.Hear(cycle=7, sender="coach", message={"kind": "weights"}), text_view) is None
    assert hear(m.Hear(cycle=7, sender="coach", message='say "x"'), text_view) is None
    right = TextView(12, "r", TEAMS, FLAG_NAMES, LINE_NAMES)
    assert hear(m.Hear(cycle=7, sender="coach", message="go"), right) == '(hear 7 online_coach_right (freeform "go"))'
    with pytest.raises(ValueError, match="direction"):
        hear(m.Hear(cycle=7, sender="opp", message="x"), text_view)


def test_a_view_is_made_from_init_ok():
    params = parameter_set("classic")
    init_ok = m.InitOk(cycle=0, side="r", unum=2, team="takers", play_mode="before_kick_off",
                       params=params.to_dict(), landmarks=to_wire(), config={})
    made = TextView.of(init_ok, 12.0, TEAMS)
    assert made == TextView(12.0, "r", TEAMS, FLAG_NAMES, LINE_NAMES, params.unum_far_length, params.team_far_length)
