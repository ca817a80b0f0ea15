"""Keeper and taker decisions, Pass and GetOpen policies (docs/players.md §2, §3,
§6, §7)."""

from __future__ import annotations

import numpy as np
import pytest

from beliefs import belief
from keepaway.agents.belief import forget_episode, new_decisions, new_memory
from keepaway.agents.config import PASS_EXTERNAL, AgentConfig
from keepaway.agents.geometry import direction
from keepaway.agents.getopen import grid_point, handcoded_target, net_size, net_value, random_target
from keepaway.agents.interception import decay_sums, fastest_to_ball
from keepaway.agents.keeper import (
    NO_PASS_DECISION,
    PASS_DECISION_START,
    PASS_DECISION_STEP,
    execute_pass_action,
    handcoded_pass,
    keeper_decide,
)
from keepaway.agents.taker import mark_point, taker_decide
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN
from keepaway.core.rng import seed_streams
from keepaway.protocol.params import parameter_set

KP = parameter_set("classic").kernel()
CFG = AgentConfig().kernel()
SUMS = decay_sums(KP, CFG)


def outputs():
    return new_decisions(1, 13)


def decide(bel, cfg=CFG, mem=None):
    """keeper_decide's code, its command's arrays (main, arg1, arg2, neck), the memory and the Pass state."""
    mem = new_memory(1, seed_streams(0, 1)) if mem is None else mem
    out = outputs()
    code = keeper_decide(bel, 0, mem, np.zeros(91), SUMS, KP, cfg, out)
    return code, (out.main, out.arg1, out.arg2, out.neck), mem, out.pass_state[0]


def pass_vector(d_k1_t1, dist2, ang2, dist3, ang3):
    """A 3v2 Pass state with only the variables P:HC reads set (indices 7, 9-12)."""
    s = np.zeros(13)
    s[7], s[9], s[10], s[11], s[12] = d_k1_t1, dist2, dist3, ang2, ang3
    return s


def test_handcoded_pass_holds_when_the_nearest_taker_is_beyond_5_m():
    # dist(K1, T1) = 6 > C1 = 5 -> hold whatever the lanes
    assert handcoded_pass(pass_vector(6.0, 20.0, 90.0, 20.0, 90.0), 3, 2, CFG) == 0


def test_handcoded_pass_passes_to_the_more_open_keeper():
    # K2: 0.25 * 40 + 10 = 20, K3: 0.25 * 60 + 12 = 27 > 22.5 -> pass to K3 (action 2)
    assert handcoded_pass(pass_vector(3.0, 10.0, 40.0, 12.0, 60.0), 3, 2, CFG) == 2
    # K2: 0.25 * 80 + 8 = 28 > K3: 27 -> action 1
    assert handcoded_pass(pass_vector(3.0, 8.0, 80.0, 12.0, 60.0), 3, 2, CFG) == 1
    # both below C3: 0.25 * 40 + 10 = 20, 0.25 * 20 + 12 = 17 -> hold
    assert handcoded_pass(pass_vector(3.0, 10.0, 40.0, 12.0, 20.0), 3, 2, CFG) == 0


# Keeper 1 has the ball at (-7, -7); from it keeper 3 (-7, 6) is 13 m away (K2) and keeper 2 (7, -5)
# 14.142 m (K3). Taker 4 presses K1 from 2 m "above" (-7, -9) (T1); taker 5 (-7, 4.5) covers keeper 3.
PRESSED = [[-6.6, -7.0], [-7.0, -7.0], [7.0, -5.0], [-7.0, 6.0], [-7.0, -9.0], [-7.0, 4.5]]


def test_keeper_with_ball_passes_to_the_open_keeper():
    # dist(K1, T1) = 2 < 5. K2 (keeper 3): nearest taker 1.5 m; angles at K1 between (0, 13) and
    # (0, -2) = 180, (0, 11.5) = 0 -> 0.25 * 0 + 1.5 = 1.5.
    # K3 (keeper 2): nearest taker |(14, 4)| = 14.560; rays (14, 2)/(0, -2): cos -0.1414 = 98.13,
    # (14, 2)/(0, 11.5): cos 0.1414 = 81.87 -> 0.25 * 81.87 + 14.560 = 35.03 > 22.5 -> PassBall to K3.
    # Still ball 0.4 m ahead: 13.746 m to keeper 2 -> n = round(8.87) = 9, v0 = 1.2/0.94^9 = 2.0943;
    # rate 0.027 (1 - 0.25 * 0.015/0.7) = 0.026855 -> power 77.98 <= 105, towards (13.6, 2): 8.366 deg
    code, (main, a1, a2, _), mem, _ = decide(belief(PRESSED, 1))
    assert code == PASS_DECISION_START
    assert mem.last_action[0] == 2 and mem.t_last[0] == 100
    assert main[0] == CMD_KICK
    assert a1[0] == pytest.approx(77.98, abs=0.01)
    assert a2[0] == pytest.approx(direction(13.6, 2.0))


def test_pass_persists_while_the_ball_stays_kickable():
    mem = new_memory(1, seed_streams(0, 1))
    mem.last_action[0], mem.t_last[0] = 1, 99  # passing to the nearest teammate since last cycle
    code, (main, _, a2, _), mem, _ = decide(belief(PRESSED, 1), mem=mem)
    assert code == NO_PASS_DECISION
    assert mem.last_action[0] == 1 and mem.t_last[0] == 100
    # the nearest teammate is keeper 3 at (-7, 6): the pass continues there although P:HC prefers K3
    assert main[0] == CMD_KICK
    assert a2[0] == pytest.approx(direction(-0.4, 13.0))


def test_external_policy_hands_the_decision_to_the_caller():
    cfg = AgentConfig(pass_policy=PASS_EXTERNAL).kernel()
    code, (main, *_), mem, state = decide(belief(PRESSED, 1), cfg=cfg)
    assert code == PASS_DECISION_START
    assert main[0] == CMD_NONE  # nothing written yet
    assert state[7] == pytest.approx(2.0)  # dist(K1, T1)
    mem.t_last[0] = 90  # decided earlier, held in between: a learner step with reward 100 - 90
    code, (main, *_), mem, _ = decide(belief(PRESSED, 1), cfg=cfg, mem=mem)
    assert code == PASS_DECISION_STEP
    out = outputs()
    execute_pass_action(belief(PRESSED, 1), 0, mem, 0, KP, cfg, out)
    assert out.main[0] == CMD_KICK and mem.last_action[0] == 0 and mem.t_last[0] == 100
    forget_episode(mem, 0)
    assert mem.last_action[0] == -1 and mem.t_last[0] == -1


def test_keeper_without_the_ball_searches_when_the_ball_is_lost():
    bel = belief(PRESSED, 2)
    bel.conf[0, 0] = 0.89  # below 0.90
    bel.neck[0, 2] = 30.0
    code, (main, _, _, neck), _, _ = decide(bel)
    assert code == NO_PASS_DECISION
    assert main[0] == CMD_TURN
    assert neck[0] == pytest.approx(-30.0)  # neck aligned with the body


def test_fastest_keeper_intercepts_and_the_others_get_open():
    # free ball at rest at (0, 0): keeper 1 at (2, 0) is fastest; keeper 2 uses GO:R and commits a target
    pos = [[0.0, 0.0], [2.0, 0.0], [7.0, 7.0], [-7.0, 7.0], [9.0, -9.0], [8.0, -9.0]]
    _, (main, a1, _, _), mem, _ = decide(belief(pos, 1, body=[0, 180, 0, 0, 0, 0]))
    assert main[0] == CMD_DASH and a1[0] > 0.0
    assert mem.intercept_time[0] == 100
    cfg = AgentConfig(getopen_policy=0).kernel()
    _, _, mem, _ = decide(belief(pos, 2), cfg=cfg)
    assert mem.has_target[0] and mem.intercept_time[0] == -1


def test_random_getopen_keeps_its_point_until_arrival():
    pos = [[0.0, 0.0], [0.5, 0.0], [9.0, 9.0], [-9.0, 9.0], [9.0, -9.0], [8.0, -9.0]]
    mem = new_memory(1, seed_streams(3, 1))
    first = random_target(belief(pos, 2), 0, mem, KP, CFG)
    assert first in [grid_point(k, KP, CFG) for k in range(25)]
    assert random_target(belief(pos, 2), 0, mem, KP, CFG) == first
    pos[2] = [first[0] + 1.0, first[1]]  # within 1.5 m: pick again
    rng_before = mem.rng.copy()
    random_target(belief(pos, 2), 0, mem, KP, CFG)
    assert mem.rng[0] != rng_before[0]


def test_grid_is_5_by_5_with_15_percent_margin():
    # 20 m: -10 + 3 + i * 3.5 -> -7, -3.5, 0, 3.5, 7; x outer, y inner
    assert grid_point(0, KP, CFG) == pytest.approx((-7.0, -7.0))
    assert grid_point(1, KP, CFG) == pytest.approx((-7.0, -3.5))
    assert grid_point(24, KP, CFG) == pytest.approx((7.0, 7.0))


# K1 = keeper 1 at (-7, 0) with the ball at (-6.5, 0) (so predictedBallPos = the ball), keeper 3 at
# (-7, -7), takers behind K1 at (-9, 1) and (-9, -1); the deciding keeper 2 stands at (0, -7).
GETOPEN_POSITION = [[-6.5, 0.0], [-7.0, 0.0], [0.0, -7.0], [-7.0, -7.0], [-9.0, 1.0], [-9.0, -1.0]]


def test_handcoded_getopen_picks_the_least_congested_admissible_point():
    # congestion (sum of 1/dist over keepers 1, 3 and both takers):
    # (7, 7): 1/15.652 + 1/19.799 + 1/17.088 + 1/17.889 = 0.2288 (the lowest of the grid)
    # (7, 3.5): 0.2484, (3.5, 7): 0.2759. Lanes from (-6.5, 0) to the right are far from the takers
    # (bearing ~158 deg), so (7, 7) is admissible.
    bel = belief(GETOPEN_POSITION, 2)
    assert fastest_to_ball(bel, 0, 1, 3, SUMS, KP, CFG) == (1, 0)  # K1 has the ball: predictedBallPos = ball
    assert handcoded_target(bel, 0, 0, False, KP, CFG) == pytest.approx((7.0, 7.0))


@pytest.mark.parametrize("cone", [False, True])
def test_handcoded_getopen_rejects_a_point_whose_lane_is_blocked(cone):
    # taker 5 moved to (-5.5, 0.52): from the ball (1, 0.52), bearing 27.47 deg, the lane to (7, 7) has
    # bearing atan(7/13.5) = 27.41 deg -> angle 0.06 < 18.4 (and inside the 0.3 cone). Congestion:
    # (7, 7) 0.2439 would still be the lowest; next (7, -7): 1/15.652 + 1/14 + 1/17.889 + 1/14.588 = 0.2598
    # with an open lane (taker 5 at 55 deg from it, taker 4 at 174 deg), (7, 3.5) 0.2660 is blocked too.
    pos = [row[:] for row in GETOPEN_POSITION]
    pos[5] = [-5.5, 0.52]
    assert handcoded_target(belief(pos, 2), 0, 0, cone, KP, CFG) == pytest.approx((7.0, -7.0))


def test_net_value_on_fixed_weights():
    # 1 input, x = 1.5; W1 = e0, b1 = 0 -> h1 = (f(1.5), 0, 0, 0, 0), f(z) = 1.7159 tanh(2z/3):
    # f(1.5) = 1.7159 tanh(1) = 1.306819. W2 row 0 = e0, b2 = (0, 0.75, 0, 0, 0)
    # -> h2 = (f(1.306819), f(0.75), 0, 0, 0) = (1.7159 * 0.701990, 1.7159 * 0.462117) = (1.204544, 0.792947).
    # W3 = (2, -1, 0, 0, 0), b3 = 0.5 -> 2 * 1.204544 - 0.792947 + 0.5 = 2.116142
    theta = np.zeros(net_size(1))
    theta[0] = 1.0  # W1[0, 0]
    w2 = 5 + 5
    theta[w2] = 1.0  # W2[0, 0]
    theta[w2 + 25 + 1] = 0.75  # b2[1]
    w3 = w2 + 25 + 5
    theta[w3], theta[w3 + 1], theta[w3 + 5] = 2.0, -1.0, 0.5
    assert net_value(theta, np.array([1.5])) == pytest.approx(2.116142, abs=1e-6)
    assert net_size(10) == 91


def test_taker_chases_a_free_ball():
    # 3v2, ball free at (0, 0), taker 4 at (5, 0) facing it: intercept -> full dash towards it
    pos = [[0.0, 0.0], [-7.0, -7.0], [7.0, -7.0], [-7.0, 7.0], [5.0, 0.0], [6.0, 6.0]]
    mem = new_memory(1, seed_streams(0, 1))
    out = outputs()
    taker_decide(belief(pos, 4, body=[0, 0, 0, 0, 180, 0]), 0, mem, SUMS, KP, CFG, out)
    assert out.main[0] == CMD_DASH and out.arg1[0] == pytest.approx(100.0)


def test_taker_holds_the_ball_it_controls():
    # taker 4 at (0, 0) facing 0, ball 0.9 m ahead, keepers far: kick it back to 0.595 m ahead.
    # rate = 0.027 (1 - 0 - 0.25 * (0.9 - 0.385)/0.7) = 0.022034; power = 0.305 / 0.022034 = 13.842, dir 180
    pos = [[0.9, 0.0], [-7.0, -7.0], [7.0, -7.0], [-7.0, 7.0], [0.0, 0.0], [6.0, 6.0]]
    out = outputs()
    taker_decide(belief(pos, 4), 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == CMD_KICK
    assert out.arg1[0] == pytest.approx(0.305 / (0.027 * (1.0 - 0.25 * 0.515 / 0.7)))
    assert abs(out.arg2[0]) == pytest.approx(180.0)


def test_taker_hold_turns_when_the_ball_is_already_in_place():
    # ball 0.5 m ahead is within 0.3 m of the 0.3 m spot (quirk of docs/players.md §5.3 step 2) and stays
    # within 0.85 x 1.085 m: turn towards the keepers' goal (-52.5, 0), i.e. by 180 deg
    pos = [[0.5, 0.0], [-7.0, -7.0], [7.0, -7.0], [-7.0, 7.0], [0.0, 0.0], [6.0, 6.0]]
    out = outputs()
    taker_decide(belief(pos, 4), 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == CMD_TURN
    assert abs(out.arg1[0]) == pytest.approx(180.0)


def test_taker_does_not_interfere_with_a_teammate_on_the_ball():
    # taker 4 controls the ball (0.5 m); taker 5 at (0, 3), still, facing 0 deg: turn to the ball,
    # direction (0.5, -3) = -80.54 deg (moment = angle at speed 0), neck aligned with the body
    pos = [[0.5, 0.0], [-7.0, -7.0], [7.0, -7.0], [-7.0, 7.0], [0.0, 0.0], [0.0, 3.0]]
    bel = belief(pos, 5)
    bel.neck[0, 5] = 20.0
    out = outputs()
    taker_decide(bel, 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == CMD_TURN
    assert out.arg1[0] == pytest.approx(direction(0.5, -3.0))
    assert out.neck[0] == pytest.approx(-20.0)


# 3v3: keeper 3 holds the ball at (0, 0); taker 4 near the lane to keeper 1 (-8, 8), taker 5 pressing the
# holder, taker 6 (the deciding one) far away at (0, -8).
MARKING = [[0.5, 0.0], [-8.0, 8.0], [8.0, 8.0], [0.0, 0.0], [-3.0, 3.0], [1.0, 0.5], [0.0, -8.0]]


def test_third_taker_marks_the_least_covered_keeper():
    # cones from keeper 3 (fastest: it has the ball): towards keeper 1 contains taker 4 (on the line);
    # towards keeper 2 (8, 8): taker 5 (1, 0.5) has along 1.06, perp 0.354 > 0.3 * 1.06 -> none;
    # towards keeper 3 itself: empty (zero length). Fewest = 0, first found = keeper 2.
    # Mark point: (8, 8) + 4 (-7.5, -8)/10.966 = (5.2643, 5.0819)
    bel = belief(MARKING, 6, n_takers=3)
    assert mark_point(bel, 0, SUMS, KP, CFG) == pytest.approx((5.2643, 5.0819), abs=1e-4)
    out = outputs()
    bel.body[0, 6] = direction(5.2643, 13.0819)  # facing the mark point -> dash
    taker_decide(bel, 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == CMD_DASH and out.arg1[0] == pytest.approx(100.0)


def test_two_closest_takers_never_mark():
    # taker 4 is the second closest of three: it chases (turns to the ball) instead of marking
    bel = belief(MARKING, 4, n_takers=3, body=[0, 0, 0, 0, 0, 0, 0])
    out = outputs()
    taker_decide(bel, 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == CMD_TURN
    assert out.arg1[0] == pytest.approx(direction(3.5, -3.0), abs=1.0)


@pytest.mark.parametrize("ball_speed, expected", [(0.0, CMD_DASH), (1.0, CMD_TURN)])
def test_taker_plans_with_the_ball_it_believes(ball_speed, expected):
    # keeper 1 controls the ball (0.5, 0). Taker 4 at (0, 4) faces -90 deg. Believed at rest (what the
    # world model believes of a ball an opponent controls): the ball lies 7.1 deg off the body line,
    # 0.5 m < 0.9 x 1.085 m -> dash. Believed rolling at 1 m/cycle: the interception point lies several
    # metres to the right, far off the body line -> turn.
    pos = [[0.5, 0.0], [0.0, 0.0], [7.0, -7.0], [-7.0, 7.0], [0.0, 4.0], [9.0, 9.0]]
    bel = belief(pos, 4, body=[0, 0, 0, 0, -90, 0])
    bel.vel[0, 0] = [ball_speed, 0.0]
    out = outputs()
    taker_decide(bel, 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, out)
    assert out.main[0] == expected
