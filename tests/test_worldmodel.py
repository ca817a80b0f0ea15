"""The players' world model (agents/tracking.py, agents/worldmodel.py): localisation, tracking, prediction, confidence.

Percepts come from the server's own perception code (`server/perception.py`) applied to exact worlds,
or are written by hand where a formula is pinned. docs/rules.md §1, §2, §5; docs/players.md §4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from keepaway.agents.belief import belief_from_truth
from keepaway.agents.config import AgentConfig
from keepaway.agents.tracking import CONF_HORIZON_CYCLES, new_model_state, new_see_buffer, see_row
from keepaway.agents.worldmodel import WorldModel
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN
from keepaway.protocol import landmarks
from keepaway.protocol.params import parameter_set
from keepaway.server.percept_wire import see_payload, sense_body_payload
from keepaway.server.perception import SeeBuffers, SenseBodyBuffers, cone_factor, fullstate, see_arena, sense_body_arena
from keepaway.server.world import new_world

PARAMS = parameter_set("classic")  # keepaway launch: visible_angle 360
KP = PARAMS.kernel()
CFG = AgentConfig().kernel()
K, T = 3, 2
N = 1 + K + T
FLAGS = landmarks.to_wire()["flags"]
# Two hand flags for hand-built sees: from (0, 0) with head 0, "east" is 10 m at 0 deg and "south"
# (+y is down) 10 m at +90 deg, so localisation gives exactly pos (0, 0), head 0.
HAND_FLAGS = [["east", 10.0, 0.0], ["south", 0.0, 10.0]]
HAND_FLAG_OBS = [[0, 10.0, 0, None, None], [1, 10.0, 90, None, None]]


def hand_see(cycle, ball=None, players=()):
    return {"cycle": cycle, "flags": HAND_FLAG_OBS, "lines": [], "ball": ball, "players": list(players)}


def sense(cycle, speed=(0.0, 0), head_angle=0, effort=1.0):
    return {"cycle": cycle, "view_mode": ["high", "normal"], "stamina": [4000.0, effort, -1.0],
            "speed": list(speed), "head_angle": head_angle, "counts": {}, "collision": []}


def world(pos, vel=None, body=None, neck=None, seed=0):
    """A 3v2 world with every player enabled at the given exact state."""
    w = new_world(PARAMS, K, T, seed=seed)
    w.enabled[:] = True
    w.pos[0] = pos
    w.vel[0] = 0.0 if vel is None else vel
    w.body[0] = 0.0 if body is None else body
    w.neck[0] = 0.0 if neck is None else neck
    return w


def percepts(w, obs, cycle):
    """The sense_body and see the server sends player ``obs`` in ``cycle`` (normal view, 360 deg)."""
    see_out = SeeBuffers.empty(1, N, KP)
    body_out = SenseBodyBuffers.empty(1, N)
    see_arena(0, w, obs, cone_factor("normal"), KP, see_out)
    sense_body_arena(0, w, obs, body_out)
    see = see_payload(see_out, 0, obs, K)
    body = sense_body_payload(body_out, 0, obs, "high", "normal")
    see["cycle"] = body["cycle"] = cycle
    return body, see


def model_for(obs, flags=FLAGS):
    side, unum = ("l", obs) if obs <= K else ("r", obs - K)
    return WorldModel(PARAMS, side, unum, K, T, flags)


def random_world(rng, me_near=(0.0, 0.0), half=10.0):
    pos = rng.uniform(-half, half, size=(N, 2))
    pos[1] = np.asarray(me_near) + rng.uniform(-half, half, size=2)
    body = rng.uniform(-180.0, 180.0, size=N)
    neck = rng.uniform(-90.0, 90.0, size=N)
    return pos, body, neck


def angle_error(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


# --------------------------------------------------------------------------------------------------
# self-localisation


def test_self_localisation_within_0_2_m_and_1_deg_in_the_central_20x20_region():
    # Flags are quantised with ln-step 0.01 (+-0.5 %) and 1 deg directions; (f c) lies inside the region,
    # so the weighted fit is dominated by it and errors stay well below 0.2 m.
    rng = np.random.default_rng(1)
    errors, head_errors = [], []
    for trial in range(200):
        pos, body, neck = random_world(rng)
        w = world(pos, body=body, neck=neck, seed=trial)
        sb, see = percepts(w, 1, 5)
        wm = model_for(1)
        wm.on_sense_body(sb)
        wm.on_see(see)
        b = wm.belief()
        errors.append(np.hypot(*(b.pos[0, 1] - pos[1])))
        head_errors.append(angle_error(b.body[0, 1] + b.neck[0, 1], body[1] + neck[1]))
    assert max(errors) < 0.2
    assert np.mean(errors) < 0.08
    assert max(head_errors) < 1.0


def test_localisation_needs_no_prior_and_recovers_from_a_wrong_one():
    # The fit of the flags gives head and position without a prior: a model that believes it is 30 m
    # away facing backwards is corrected by one see.
    pos = np.array([[3.0, 2.0], [4.0, -5.0], [0, 0], [0, 5], [6, 6], [-6, 6]])
    w = world(pos, body=np.full(N, 120.0), neck=np.full(N, -40.0))
    sb, see = percepts(w, 1, 7)
    wm = model_for(1)
    wm.on_fullstate({"cycle": 6, "ball": [0, 0, 0, 0],
                     "players": [["l", 1, -26.0, 20.0, 0, 0, -60.0, -40.0, 4000, 1, 1, -1]]})
    wm.on_sense_body(sb)
    wm.on_see(see)
    b = wm.belief()
    assert np.hypot(*(b.pos[0, 1] - pos[1])) < 0.2
    assert angle_error(b.body[0, 1], 120.0) < 1.0


def test_hand_flags_give_exact_position_and_head():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3))
    b = wm.belief()
    assert b.pos[0, 1] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert b.body[0, 1] == pytest.approx(0.0, abs=1e-12)


# --------------------------------------------------------------------------------------------------
# sense_body


def test_sense_body_velocity_uses_the_centre_of_the_truncated_direction():
    # speed 0.5 at -30 (truncated, so the true direction is in (-31, -30]); head 0 -> direction -30.5:
    # v = 0.5 (cos -30.5, sin -30.5) = 0.5 (0.861629, -0.507538) = (0.430815, -0.253769)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3, speed=(0.5, -30)))
    wm.on_see(hand_see(3))
    assert wm.belief().vel[0, 1] == pytest.approx([0.430815, -0.253769], abs=1e-6)


def test_neck_kept_when_consistent_with_head_angle_else_reset_to_its_centre():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    wm.on_own_commands(CMD_NONE, 0.0, 0.0, 30.4)
    wm.on_sense_body(sense(2, head_angle=30))  # trunc(30.4) = 30: prediction kept
    assert wm.belief().neck[0, 1] == pytest.approx(30.4)
    wm.on_sense_body(sense(3, head_angle=-45))  # inconsistent: centre of (-46, -45] is -45.5
    assert wm.belief().neck[0, 1] == pytest.approx(-45.5)


def test_velocity_from_sense_body_matches_the_server_within_its_quantisation():
    rng = np.random.default_rng(2)
    for trial in range(50):
        pos, body, neck = random_world(rng)
        vel = rng.uniform(-0.5, 0.5, size=(N, 2))
        w = world(pos, vel, body, neck, seed=trial)
        sb, see = percepts(w, 1, 5)
        wm = model_for(1)
        wm.on_sense_body(sb)
        wm.on_see(see)
        # |v| within 0.005 (Q step 0.01) and direction within 0.5 deg of the interval centre, plus the
        # head error (< 1 deg): 0.005 + 0.71 * 1.5 deg in rad = 0.0236
        assert np.hypot(*(wm.belief().vel[0, 1] - vel[1])) < 0.024


# --------------------------------------------------------------------------------------------------
# own motion prediction (docs/rules.md §1, §2)


@pytest.mark.parametrize("sensed, moved", [(0.24, 0.6), (0.1, 0.25)])
def test_dash_moves_me_by_the_sensed_speed(sensed, moved):
    # a = effort 1 * 100 * 0.006 = 0.6; p += 0.6; v = 0.6 * 0.4 = 0.24 (tests/data/rcss-traces/README.md,
    # "Hand checks"): sensed 0.24, I moved 0.24 / 0.4 = 0.6, as predicted. Sensed 0.1 (no ball near, no
    # collision guessed): as the C++ (updateAgentAndBallAfterSense) I moved by the speed before decay,
    # 0.1 / 0.4 = 0.25
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3))
    wm.on_own_commands(CMD_DASH, 100.0, 0.0)
    wm.on_sense_body(sense(4, speed=(sensed, 0)))
    b = wm.belief()
    assert not wm.state.collided[0]
    assert b.pos[0, 1] == pytest.approx([moved, 0.0])
    assert b.vel[0, 1] == pytest.approx([sensed, 0.0])


def test_dash_uses_effort():
    # effort 0.8: a = 0.8 * 50 * 0.006 = 0.24, predicted to (0.24, 0). The sensed speed 0 with the still
    # ball 0.26 m from there reads as a collision, so the predicted position stands
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3, effort=0.8))
    wm.on_see(hand_see(3, ball=[0.5, 0, 0.0, 0.0]))
    wm.on_own_commands(CMD_DASH, 50.0, 0.0)
    wm.on_sense_body(sense(4, effort=0.8))
    assert wm.state.collided[0]
    assert wm.belief().pos[0, 1] == pytest.approx([0.24, 0.0])


def test_a_backward_dash_is_believed_to_move_me_back():
    # CURRENT (min_dash_power 0): the server ignores dash -100, but the players believe in it as the C++
    # ones do (min_power -100): from rest, a = -100 * 0.006 = -0.6, predicted to (-0.6, 0). With the ball
    # 0.5 m behind and a sensed speed 0, the C++ guesses a collision and keeps that position
    wm = WorldModel(parameter_set("current"), "l", 1, K, T, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[0.5, 180, 0.0, 0.0]))
    wm.on_own_commands(CMD_DASH, -100.0, 0.0)
    wm.on_sense_body(sense(4))
    assert wm.state.collided[0]
    assert wm.belief().pos[0, 1] == pytest.approx([-0.6, 0.0])


def test_turn_with_inertia_and_turn_neck():
    # reported speed 0.2: body += 90 / (1 + 5 * 0.2) = 45; neck 0 + 30
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3, speed=(0.2, 0)))
    wm.on_see(hand_see(3))
    wm.on_own_commands(CMD_TURN, 90.0, 0.0, 30.0)
    wm.on_sense_body(sense(4, speed=(0.08, -75), head_angle=30))
    b = wm.belief()
    assert b.body[0, 1] == pytest.approx(45.0)
    assert b.neck[0, 1] == pytest.approx(30.0)
    # moved by the sensed speed before decay, 0.08 / 0.4 = 0.2, towards head 75 + the truncated -75's
    # centre -75.5 = -0.5 deg: (0.2 cos 0.5 deg, -0.2 sin 0.5 deg)
    assert b.pos[0, 1] == pytest.approx([0.199992385, -0.001745307])


def test_own_kick_accelerates_the_predicted_ball():
    # ball 0.5 ahead, still; kick 100 at 0: eff = 100 * 0.027 * (1 - 0.25 * (0.5 - 0.385)/0.7)
    # = 2.58911; ball x = 0.5 + 2.58911 = 3.08911, v = 2.58911 * 0.94 = 2.43376 (tests/data/rcss-traces/README.md)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[0.5, 0, 0.0, 0.0]))
    wm.on_own_commands(CMD_KICK, 100.0, 0.0)
    wm.on_sense_body(sense(4))
    b = wm.belief()
    assert b.pos[0, 0] == pytest.approx([3.08911, 0.0], abs=1e-5)
    assert b.vel[0, 0] == pytest.approx([2.43376, 0.0], abs=1e-5)


def test_kick_out_of_reach_does_nothing():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[2.0, 0, 0.0, 0.0]))
    wm.on_own_commands(CMD_KICK, 100.0, 0.0)
    wm.on_sense_body(sense(4))
    assert wm.belief().pos[0, 0] == pytest.approx([2.0, 0.0])
    assert wm.belief().vel[0, 0] == pytest.approx([0.0, 0.0])


# --------------------------------------------------------------------------------------------------
# ball


def test_ball_position_error_at_10_m():
    # d' = Q(exp(Q(ln d, 0.1)), 0.1) for d in [9.5, 10.5]: radial error <= 10.5 (e^0.05 - 1) + 0.05 =
    # 0.588, lateral <= 10.5 rad(0.5) = 0.092, plus self-localisation (< 0.1): max < 0.7; the radial
    # error is spread over +-5 %, so the mean stays near a quarter of that.
    rng = np.random.default_rng(3)
    errors = []
    for trial in range(300):
        pos, body, neck = random_world(rng)
        a = rng.uniform(-math.pi, math.pi)
        pos[0] = pos[1] + rng.uniform(9.5, 10.5) * np.array([math.cos(a), math.sin(a)])
        w = world(pos, body=body, neck=neck, seed=trial)
        sb, see = percepts(w, 1, 5)
        wm = model_for(1)
        wm.on_sense_body(sb)
        wm.on_see(see)
        errors.append(np.hypot(*(wm.belief().pos[0, 0] - pos[0])))
    assert max(errors) < 0.7
    assert np.mean(errors) < 0.3


def test_ball_velocity_from_the_change_pair_by_hand():
    # ball 5 m ahead: dist_chg -0.5 along e = (1, 0), dir_chg 2 deg: rad(2) * 5 = 0.174533 along
    # e_perp = (0, 1); I am still: v = (-0.5, 0.174533)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[5.0, 0, -0.5, 2.0]))
    b = wm.belief()
    assert b.pos[0, 0] == pytest.approx([5.0, 0.0])
    assert b.vel[0, 0] == pytest.approx([-0.5, 0.174533], abs=1e-6)


def test_ball_velocity_from_the_change_pair_of_the_server():
    # dist_chg = d' Q(vr.e / d, 0.02): error <= 0.01 d' + 6 % of the radial speed; dir_chg step 0.1 deg:
    # error <= rad(0.05) d'; my own velocity error <= 0.024 (sense_body test). At d <= 15, |v| <= 2.5:
    # 0.15 + 0.15 + 0.013 + 0.024 < 0.35; typically much less.
    rng = np.random.default_rng(4)
    errors = []
    for trial in range(200):
        pos, body, neck = random_world(rng)
        d = rng.uniform(3.0, 15.0)
        a = rng.uniform(-math.pi, math.pi)
        pos[0] = pos[1] + d * np.array([math.cos(a), math.sin(a)])
        vel = np.zeros((N, 2))
        vel[0] = rng.uniform(-1.8, 1.8, size=2)
        vel[1] = rng.uniform(-0.4, 0.4, size=2)
        w = world(pos, vel, body, neck, seed=trial)
        if np.hypot(*(pos[K + 1:] - pos[0]).T).min() < 3.0:
            continue  # a taker that may seem to control the ball stops it (test below)
        sb, see = percepts(w, 1, 5)
        assert see["ball"][2] is not None  # d < 20: the change pair is always sent
        wm = model_for(1)
        wm.on_sense_body(sb)
        wm.on_see(see)
        errors.append(np.hypot(*(wm.belief().vel[0, 0] - vel[0])))
    assert len(errors) > 150
    assert max(errors) < 0.35
    assert np.mean(errors) < 0.1


def test_ball_velocity_from_successive_positions_without_the_change_pair():
    # ball at (1.5, 0), then 2 cycles later at (2.47, 0) with no change pair, within visible_distance
    # (3 m): displacement 0.97 = v0 (1 + 0.94) -> v0 = 0.5, v after one cycle 0.47; the ball was then at
    # 2.0, 2 m from me (beyond 1.085): v = 0.47 * 0.94 = 0.4418 (WorldModel::calculateStateBall)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[1.5, 0, None, None]))
    wm.on_sense_body(sense(4))
    wm.on_sense_body(sense(5))
    wm.on_see(hand_see(5, ball=[2.47, 0, None, None]))
    assert wm.belief().vel[0, 0] == pytest.approx([0.4418, 0.0])


@pytest.mark.parametrize("first, second, expected", [
    (2.0, 2.5, 0.47),  # 0.5 m in one cycle: v = 0.5 * 0.94 = 0.47
    (5.0, 5.5, 0.0),  # beyond visible_distance 3 m the C++ keeps the predicted velocity (0 here)
])
def test_ball_velocity_from_positions_one_cycle_apart(first, second, expected):
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[first, 0, None, None]))
    wm.on_sense_body(sense(4))
    wm.on_see(hand_see(4, ball=[second, 0, None, None]))
    assert wm.belief().vel[0, 0] == pytest.approx([expected, 0.0])


def test_position_difference_discounts_my_localisation_correction():
    # I believe I stand at (0, 0); the next see puts me at (0.1, 0) (east flag 9.9 m at 0 deg, south
    # flag hypot(0.1, 10) at atan2(10, -0.1)) and the ball 2.5 m ahead, at (2.6, 0). The ball moved
    # 2.6 - 2.0 = 0.6 m, of which 0.1 is my own correction: v = 0.5 * 0.94 = 0.47 (not 0.564)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[2.0, 0, None, None]))
    wm.on_sense_body(sense(4))
    flags = [[0, 9.9, 0, None, None], [1, math.hypot(0.1, 10.0), math.degrees(math.atan2(10.0, -0.1)), None, None]]
    wm.on_see({"cycle": 4, "flags": flags, "lines": [], "ball": [2.5, 0, None, None], "players": []})
    b = wm.belief()
    assert b.pos[0, 1] == pytest.approx([0.1, 0.0], abs=1e-9)
    assert b.vel[0, 0] == pytest.approx([0.47, 0.0])


@pytest.mark.parametrize("case", ["teammate near the ball", "my kick"])
def test_position_difference_over_two_cycles_refused_where_the_ball_could_have_been_kicked(case):
    # As the 2-cycle test above (the ball a cycle ago at 2.0), but a teammate stands at 2.3 (0.3 m from
    # it) or I sent a kick: the predicted velocity (0) stays (WorldModel::calculateStateBall)
    wm = model_for(1, HAND_FLAGS)
    mate = [["l", 2, 2.3, 0, 0.0, 0.0, 0, 0]] if case == "teammate near the ball" else []
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[1.5, 0, None, None], players=mate))
    wm.on_sense_body(sense(4))
    if case == "my kick":
        wm.on_own_commands(CMD_KICK, 100.0, 0.0)  # ball 1.5 m away: not kickable, but a kick was sent
    wm.on_sense_body(sense(5))
    wm.on_see(hand_see(5, ball=[2.47, 0, None, None], players=mate))
    assert wm.belief().vel[0, 0] == pytest.approx([0.0, 0.0])


def test_seen_ball_velocity_averaged_with_a_close_prediction():
    # see 3: v = (-0.5, 0); predicted at 4: (-0.47, 0). The change pair says (-0.48, 0): within
    # 2 ball_rand |v_pred| = 0.047 of it in x and y, so the average (-0.475, 0); (-0.3, 0) differs by 0.17:
    # taken as seen (WorldModel::calculateStateBall)
    for seen, expected in ((-0.48, -0.475), (-0.3, -0.3)):
        wm = model_for(1, HAND_FLAGS)
        wm.on_sense_body(sense(3))
        wm.on_see(hand_see(3, ball=[5.0, 0, -0.5, 0.0]))
        wm.on_sense_body(sense(4))
        wm.on_see(hand_see(4, ball=[4.5, 0, seen, 0.0]))
        assert wm.belief().vel[0, 0] == pytest.approx([expected, 0.0])


def test_seen_ball_speed_above_max_with_noise_is_cut_to_max():
    # ball_speed_max 2.7, ball_rand 0.05: 3.0 > 2.835 becomes 2.7; 2.8 stays
    for seen, expected in ((-3.0, -2.7), (-2.8, -2.8)):
        wm = model_for(1, HAND_FLAGS)
        wm.on_sense_body(sense(3))
        wm.on_see(hand_see(3, ball=[5.0, 0, seen, 0.0]))
        assert wm.belief().vel[0, 0] == pytest.approx([expected, 0.0])


# (me, the other player seen): a keeper seeing a taker, a taker seeing a keeper, a keeper its teammate
OPPONENT = [(1, ["r", 2]), (K + 1, ["l", 2])]
TEAMMATE = [(1, ["l", 2])]


@pytest.mark.parametrize("me, other", OPPONENT)
def test_seen_ball_stops_where_an_opponent_can_kick_it(me, other):
    # ball 5 m ahead with change pair (-0.5, 2 deg) -> (-0.5, 0.174533) if free; an opponent 0.5 m
    # behind it can kick it: v = 0 (WorldModel::calculateStateBall), for keepers and takers alike
    wm = model_for(me, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[5.0, 0, -0.5, 2.0], players=[[*other, 5.5, 0, 0.0, 0.0, 0, 0]]))
    assert wm.belief().vel[0, 0] == pytest.approx([0.0, 0.0])


@pytest.mark.parametrize("me, other", OPPONENT + TEAMMATE)
def test_seen_ball_keeps_its_velocity_when_i_can_kick_it_or_a_teammate_is_near(me, other):
    # ball 1.0 m ahead (within my 1.085 m) with an opponent 0.5 m behind it: v = (-0.5, rad(2) * 1.0);
    # and 5 m ahead next to a teammate: (-0.5, rad(2) * 5)
    near = 1.0 if other[0] != ("l" if me <= K else "r") else 5.0
    wm = model_for(me, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[near, 0, -0.5, 2.0], players=[[*other, near + 0.5, 0, 0.0, 0.0, 0, 0]]))
    assert wm.belief().vel[0, 0] == pytest.approx([-0.5, math.radians(2.0) * near])


def test_an_opponent_unseen_for_13_cycles_no_longer_stops_the_ball():
    # conf >= 0.88 (player_conf_threshold) makes a player count: seen 12 cycles ago (conf 0.88) he
    # stops the ball, 13 cycles ago (0.87) he does not
    for age, expected in ((12, [0.0, 0.0]), (13, [-0.5, 0.174533])):
        wm = model_for(1, HAND_FLAGS)
        wm.on_sense_body(sense(3))
        wm.on_see(hand_see(3, players=[["r", 1, 5.5, 0, 0.0, 0.0, 0, 0]]))
        for cycle in range(4, 4 + age):
            wm.on_sense_body(sense(cycle))
        wm.on_see(hand_see(3 + age, ball=[5.0, 0, -0.5, 2.0]))
        assert wm.belief().vel[0, 0] == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize("me, other", OPPONENT + TEAMMATE)
def test_predicted_ball_stops_when_it_rolls_into_an_opponents_reach(me, other):
    # ball at 5 m rolling away at 0.5 (dist_chg +0.5), the other player still at 6.8 m. Cycle 4: ball
    # at 5.5 (1.3 m from him), v 0.47; cycle 5: at 5.97 (0.83 m < 1.085): an opponent controls it,
    # v = 0 (WorldModel::updateDynamicObjectForNextCycle); a teammate does not stop it: v = 0.4418
    wm = model_for(me, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[5.0, 0, 0.5, 0.0], players=[[*other, 6.8, 0, 0.0, 0.0, 0, 0]]))
    wm.on_sense_body(sense(4))
    assert wm.belief().vel[0, 0] == pytest.approx([0.47, 0.0])
    wm.on_sense_body(sense(5))
    b = wm.belief()
    assert b.pos[0, 0] == pytest.approx([5.97, 0.0])
    opponent = other[0] != ("l" if me <= K else "r")
    assert b.vel[0, 0] == pytest.approx([0.0, 0.0] if opponent else [0.4418, 0.0])


def test_collision_guessed_from_a_zero_speed_moves_the_ball_out_of_me():
    # I dash 100 from rest (predicted to (0.6, 0), v 0.24) towards a ball at 0.5 m rolling at -0.1. The
    # predicted ball is at 0.4 (v -0.094), 0.2 m from me; sense_body reports speed 0: a collision
    # (zero speed, predicted > 0.01, ball within 0.8 m). No player is nearer, so the ball goes 0.2 m
    # from me towards where it was, (0.4, 0), its velocity x -0.1 = 0.0094; I stay where the dash was
    # predicted to take me (WorldModel::updateAgentAndBallAfterSense, updateBallForCollision).
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[0.5, 0, -0.1, 0.0]))
    wm.on_own_commands(CMD_DASH, 100.0, 0.0)
    wm.on_sense_body(sense(4))
    b = wm.belief()
    assert b.pos[0, 0] == pytest.approx([0.4, 0.0])
    assert b.vel[0, 0] == pytest.approx([0.0094, 0.0])
    assert b.pos[0, 1] == pytest.approx([0.6, 0.0])
    assert wm.state.collided[0] and wm.state.collision_time[0] == 4


def test_no_collision_when_the_sensed_speed_matches_the_prediction():
    # the same with speed 0.24 reported: the predicted ball stays at 0.4 with v -0.094
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[0.5, 0, -0.1, 0.0]))
    wm.on_own_commands(CMD_DASH, 100.0, 0.0)
    wm.on_sense_body(sense(4, speed=(0.24, 0)))
    b = wm.belief()
    assert b.vel[0, 0] == pytest.approx([-0.094, 0.0])
    assert not wm.state.collided[0]


def test_collision_from_a_sharp_speed_drop_near_the_ball():
    # moving at 0.5 along x (sense 3), the ball 1.5 m ahead moving with me (change pair -0.5: still), I
    # dash 100: v = 0.5 + 0.6 = 1.1 (below player_speed_max 1.2), at (1.1, 0) with v 0.44 after decay;
    # the ball, 0.4 m away, is within 1.085 + 0.5. Sensed speed 0.05 along -x: x flipped, y below 0.08,
    # and 0.05 < 0.25 * 0.44 -> collision; the ball goes 0.2 m from me, to (1.3, 0)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3, speed=(0.5, 0)))
    wm.on_see(hand_see(3, ball=[1.5, 0, -0.5, 0.0]))
    wm.on_own_commands(CMD_DASH, 100.0, 0.0)
    wm.on_sense_body(sense(4, speed=(0.05, 180)))
    assert wm.state.collided[0]
    assert wm.belief().pos[0, 0] == pytest.approx([1.3, 0.0])


def test_prediction_between_sees_follows_ball_decay():
    # v = (-0.5, 0.174533) at (5, 0); after 2 unseen cycles: p = p0 + v (1 + 0.94) =
    # (4.03, 0.338594), v = v 0.94^2 = (-0.4418, 0.154217)
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(3))
    wm.on_see(hand_see(3, ball=[5.0, 0, -0.5, 2.0]))
    wm.on_sense_body(sense(4))
    wm.on_sense_body(sense(5))
    b = wm.belief()
    assert b.pos[0, 0] == pytest.approx([4.03, 0.338594], abs=1e-6)
    assert b.vel[0, 0] == pytest.approx([-0.4418, 0.154217], abs=1e-6)


def test_confidence_decays_by_one_hundredth_per_unseen_cycle():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(10))
    wm.on_see(hand_see(10, ball=[5.0, 0, 0.0, 0.0], players=[["l", 2, 4.0, 90, 0.0, 0.0, 0, 0]]))
    assert wm.belief().conf[0, 0] == 1.0
    for cycle in range(11, 21):
        wm.on_sense_body(sense(cycle))
    b = wm.belief()
    assert CONF_HORIZON_CYCLES == 100.0
    assert b.conf[0, 0] == pytest.approx(0.90)  # 1 - 10/100: still "known" (docs/players.md §4.1)
    assert b.conf[0, 2] == pytest.approx(0.90)
    assert b.conf[0, 1] == 1.0  # myself
    assert b.conf[0, 3] == 0.0  # never seen
    wm.on_sense_body(sense(21))
    assert wm.belief().conf[0, 0] == pytest.approx(0.89)


def test_ball_tracked_along_a_roll_with_the_server_percepts():
    # The ball rolls with decay 0.94 past a still observer; sees on 2 of 3 cycles. The estimate stays
    # within the quantisation bounds on seen and unseen cycles alike.
    pos = np.array([[-8.0, 3.0], [0.0, 0.0], [5, 5], [-5, 5], [5, -5], [-5, -5]])
    vel = np.zeros((N, 2))
    vel[0] = [1.5, -0.3]
    w = world(pos, vel, body=np.full(N, 30.0))
    wm = model_for(1)
    for cycle in range(1, 16):
        sb, see = percepts(w, 1, cycle)
        wm.on_sense_body(sb)
        if cycle % 3 != 2:
            wm.on_see(see)
        b = wm.belief()
        d = np.hypot(*w.pos[0, 0])
        assert np.hypot(*(b.pos[0, 0] - w.pos[0, 0])) < 0.06 * d + 0.25
        assert np.hypot(*(b.vel[0, 0] - w.vel[0, 0])) < 0.012 * d + 0.1
        w.pos[0, 0] += w.vel[0, 0]
        w.vel[0, 0] *= PARAMS.ball_decay


# --------------------------------------------------------------------------------------------------
# players


def test_named_player_position_velocity_and_facing():
    rng = np.random.default_rng(5)
    for trial in range(50):
        pos, body, neck = random_world(rng, half=7.0)
        vel = rng.uniform(-0.5, 0.5, size=(N, 2))
        w = world(pos, vel, body, neck, seed=trial)
        sb, see = percepts(w, 1, 5)
        wm = model_for(1)
        wm.on_sense_body(sb)
        wm.on_see(see)
        b = wm.belief()
        for obj in range(2, N):
            d = np.hypot(*(pos[obj] - pos[1]))
            # 5 % radial (ln step 0.1) + 0.05 print + 1 deg lateral + self error
            assert np.hypot(*(b.pos[0, obj] - pos[obj])) < 0.06 * d + 0.25
            # dist_chg 1 % of d, dir_chg 0.05 deg, plus my velocity error
            assert np.hypot(*(b.vel[0, obj] - vel[obj])) < 0.012 * d + 0.1
            # body_dir/head_dir rounded to 1 deg plus the head error
            assert angle_error(b.body[0, obj], body[obj]) < 1.6
            assert angle_error(b.neck[0, obj], neck[obj]) < 2.2
            assert b.conf[0, obj] == 1.0


def test_unnamed_players_are_associated_with_the_nearest_compatible_prediction():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    # keepers 2, 3 and takers 4, 5 seen by name, all still
    wm.on_see(hand_see(1, players=[
        ["l", 2, 10.0, 0, 0.0, 0.0, 0, 0],
        ["l", 3, 10.0, 90, 0.0, 0.0, 0, 0],
        ["r", 1, 10.0, 180, 0.0, 0.0, 0, 0],
        ["r", 2, 10.0, -90, 0.0, 0.0, 0, 0],
    ]))
    wm.on_sense_body(sense(2))
    # then, in scrambled order and with names missing: taker 1 anonymous where it was (-10, 0), taker 2
    # by side only at (0, -11), keeper 3 anonymous at (0, 11), keeper 2 by side only at (11, 0)
    wm.on_see(hand_see(2, players=[
        [None, None, 10.0, 180, None, None, None, None],
        ["r", None, 11.0, -90, None, None, None, None],
        [None, None, 11.0, 90, None, None, None, None],
        ["l", None, 11.0, 0, None, None, None, None],
    ]))
    b = wm.belief()
    assert b.pos[0, 2] == pytest.approx([11.0, 0.0], abs=1e-9)
    assert b.pos[0, 3] == pytest.approx([0.0, 11.0], abs=1e-9)
    assert b.pos[0, 4] == pytest.approx([-10.0, 0.0], abs=1e-9)
    assert b.pos[0, 5] == pytest.approx([0.0, -11.0], abs=1e-9)
    assert (b.conf[0, 2:] == 1.0).all()


def test_side_constrains_association_even_when_another_player_is_nearer():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    wm.on_see(hand_see(1, players=[["l", 2, 10.0, 0, 0.0, 0.0, 0, 0], ["r", 1, 10.0, 5, 0.0, 0.0, 0, 0]]))
    wm.on_sense_body(sense(2))
    # a taker seen right where keeper 2 was, 0.87 m from taker 1 (within its 1.2 m reach): it must be
    # taker 1 (object K + 1 = 4), not keeper 2 (wrong side) nor the never-seen taker 2
    wm.on_see(hand_see(2, players=[["r", None, 10.0, 0, None, None, None, None]]))
    b = wm.belief()
    assert b.pos[0, 4] == pytest.approx([10.0, 0.0], abs=1e-9)
    assert b.conf[0, 2] == pytest.approx(0.99)  # keeper 2 not seen this cycle
    assert b.conf[0, 5] == 0.0


def test_named_observation_wins_over_unnamed_association():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    wm.on_see(hand_see(1, players=[["l", 2, 10.0, 0, 0.0, 0.0, 0, 0], ["l", 3, 10.0, 90, 0.0, 0.0, 0, 0]]))
    wm.on_sense_body(sense(2))
    # the unnamed keeper (listed first) is nearest keeper 2's old place, but keeper 2 is also seen by
    # name elsewhere, so the unnamed one must be keeper 3
    wm.on_see(hand_see(2, players=[
        ["l", None, 10.0, 5, None, None, None, None],
        ["l", 2, 10.0, 40, 0.0, 0.0, 0, 0],
    ]))
    b = wm.belief()
    assert b.pos[0, 2] == pytest.approx([10 * math.cos(math.radians(40)), 10 * math.sin(math.radians(40))])
    assert b.pos[0, 3] == pytest.approx([10 * math.cos(math.radians(5)), 10 * math.sin(math.radians(5))])


def test_out_of_reach_player_loses_to_a_never_seen_one():
    # keeper 2 was seen 1 cycle ago 10 m east; a keeper appears 20 m west: it cannot be keeper 2 (it
    # moves at most 1.2 m per cycle), so it is the never-seen keeper 3
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    wm.on_see(hand_see(1, players=[["l", 2, 10.0, 0, 0.0, 0.0, 0, 0]]))
    wm.on_sense_body(sense(2))
    wm.on_see(hand_see(2, players=[["l", None, 20.0, 180, None, None, None, None]]))
    b = wm.belief()
    assert b.pos[0, 3] == pytest.approx([-20.0, 0.0], abs=1e-9)
    assert b.pos[0, 2] == pytest.approx([10.0, 0.0], abs=1e-9)


def test_tracking_far_players_from_the_server_keeps_identities():
    # Everyone far (>= 20 m) from the observer loses unums at random; players walk slowly, so the
    # association keeps each on its own track over many sees.
    rng = np.random.default_rng(6)
    pos = np.array([[0.0, 0.0], [-30.0, 0.0], [5.0, -8.0], [5.0, 8.0], [8.0, -2.0], [8.0, 2.0]])
    vel = np.zeros((N, 2))
    w = world(pos, vel, seed=7)
    wm = model_for(1)
    for cycle in range(1, 40):
        vel[2:] = rng.uniform(-0.15, 0.15, size=(N - 2, 2))
        w.vel[0] = vel
        sb, see = percepts(w, 1, cycle)
        wm.on_sense_body(sb)
        wm.on_see(see)
        b = wm.belief()
        for obj in range(2, N):
            assert np.hypot(*(b.pos[0, obj] - w.pos[0, obj])) < 2.5, (cycle, obj)
        w.pos[0] += w.vel[0]


# --------------------------------------------------------------------------------------------------
# episode boundary and fullstate


def test_forget_clears_every_object_but_me():
    wm = model_for(1, HAND_FLAGS)
    wm.on_sense_body(sense(1))
    wm.on_see(hand_see(1, ball=[5.0, 0, 0.3, 0.0], players=[["l", 2, 10.0, 0, 0.0, 0.0, 0, 0]]))
    wm.forget()
    b = wm.belief()
    assert b.conf[0, 1] == 1.0
    assert (np.delete(b.conf[0], 1) == 0.0).all()
    assert b.vel[0, 0] == pytest.approx([0.0, 0.0])
    # after forgetting, an unnamed keeper is not tied to keeper 2's old track
    wm.on_sense_body(sense(2))
    wm.on_see(hand_see(2, players=[["l", None, 10.0, 0, None, None, None, None]]))
    assert wm.belief().conf[0, 2:4].tolist() in ([1.0, 0.0], [0.0, 1.0])


def test_fullstate_gives_the_exact_belief():
    rng = np.random.default_rng(8)
    pos, body, neck = random_world(rng)
    body[0] = neck[0] = 0.0  # the ball has no facing
    vel = rng.uniform(-0.5, 0.5, size=(N, 2))
    w = world(pos, vel, body, neck)
    wm = model_for(4)  # taker 1
    wm.on_fullstate({"cycle": 12, **fullstate(w, 0)})
    b = wm.belief()
    truth = belief_from_truth(pos, vel, body, neck, 4, 12, K, T)
    for name in ("time", "me", "pos", "vel", "body", "neck", "conf"):
        assert np.array_equal(getattr(b, name), getattr(truth, name)), name
    # the noisy percepts of the same cycle do not spoil it
    sb, see = percepts(w, 4, 12)
    wm.on_sense_body(sb)
    wm.on_see(see)
    assert np.array_equal(wm.belief().pos, truth.pos)


def test_rows_of_a_batch_are_independent():
    # two players' models in one state: a see for row 1 only moves row 1
    s = new_model_state(2, K, T, np.array([1, 2]), PARAMS)
    see = new_see_buffer(2, 2, N)
    flag_pos = np.array([f[1:] for f in HAND_FLAGS])
    flag_pos.setflags(write=False)  # as the modes pass it: the compiled see_row is loaded, not compiled again
    see.n_flags[:] = 2
    see.flag_id[:, :2] = [0, 1]
    see.flag_obs[0, :2] = [[10.0, 0.0], [10.0, 90.0]]  # row 0 at (0, 0), head 0
    see.flag_obs[1, :2] = [[5.0, 0.0], [np.hypot(5.0, 10.0), np.degrees(np.arctan2(10.0, -5.0))]]
    see.cycle[:] = [-1, 4]
    for r in range(2):
        see_row(r, s, see, flag_pos, K, KP, CFG)
    assert s.time.tolist() == [-1, 4]
    assert s.pos[0, 1] == pytest.approx([0.0, 0.0])
    assert s.pos[1, 2] == pytest.approx([5.0, 0.0])  # (10, 0) 5 m ahead, (0, 10) at (-5, 10)
    assert s.body[1, 2] == pytest.approx(0.0, abs=1e-9)


def test_me_follows_side_and_unum():
    assert model_for(2).me == 2
    assert model_for(5).me == 5  # taker 2 = K + 2
    with pytest.raises(ValueError):
        WorldModel(PARAMS, "r", 3, K, T, FLAGS)


def test_an_exact_ball_at_an_opponents_feet_is_believed_still():
    # keeper 1 at (0, 0) with the ball 0.5 m ahead, moving after its kick; taker 1 at (3, 0)
    pos = np.zeros((N, 2))
    pos[0] = [0.5, 0.0]
    pos[2:] = [[5.0, 5.0], [-5.0, 5.0], [3.0, 0.0], [3.0, 8.0]]
    vel = np.zeros((N, 2))
    vel[0] = [0.4, 0.2]
    w = world(pos, vel, np.zeros(N), np.zeros(N))
    taker, keeper = model_for(4), model_for(1)
    for wm in (taker, keeper):
        wm.on_fullstate({"cycle": 12, **fullstate(w, 0)})
    assert taker.belief().vel[0, 0].tolist() == [0.0, 0.0]  # a keeper controls it
    assert keeper.belief().vel[0, 0] == pytest.approx([0.4, 0.2])  # its own ball: exact
