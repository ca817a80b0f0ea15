"""Skills pinned by hand computations from docs/players.md §5 (classic parameters, keepaway launch)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from beliefs import belief
from keepaway.agents.belief import belief_from_truth, new_memory
from keepaway.agents.config import AgentConfig
from keepaway.agents.geometry import (
    ball_after_kick,
    forward_angle,
    geometric_sum,
    kick_rate,
    normalize_angle,
    player_step,
    turn_moment,
    vertex_angle,
    vertex_angle_below,
)
from keepaway.agents.interception import (
    UNKNOWN_FIRST,
    _longest_run,
    close_intercept,
    decay_sums,
    fastest_to_ball,
    intercept,
    intercept_move,
    interception_point,
)
from keepaway.agents.kicks import hold_ball, kick_close_to_body, pass_ball, pass_initial_speed
from keepaway.agents.movement import go_to_point, search_ball
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_TURN
from keepaway.core.rng import seed_streams
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame

KP = parameter_set("classic").kernel()
CFG = AgentConfig().kernel()
SUMS = decay_sums(KP, CFG)


FAR_TAKERS = [[9.0, 9.0], [9.0, -9.0]]


def test_normalize_angle_and_vertex_angle():
    assert normalize_angle(190.0) == pytest.approx(-170.0)
    assert normalize_angle(-180.0) == pytest.approx(180.0)
    assert normalize_angle(540.0) == pytest.approx(180.0)
    # rays (4, 3) and (4, 0) from the origin: cos = 16/20 = 0.8 -> 36.8699 deg
    assert vertex_angle(4.0, 3.0, 0.0, 0.0, 4.0, 0.0) == pytest.approx(36.8699, abs=1e-4)


@pytest.mark.parametrize("limit, below", [(40.0, True), (30.0, False), (36.8698, False), (36.8699, True)])
def test_vertex_angle_below_decides_as_the_angle(limit, below):
    # the same rays: 36.869898 deg; below 40 and 36.8699, not below 30 nor 36.8698 (the estimate decides)
    cos_limit = math.cos(math.radians(limit))
    assert vertex_angle_below(4.0, 3.0, 0.0, 0.0, 4.0, 0.0, limit, cos_limit) is below


def test_vertex_angle_below_at_the_limit_asks_the_exact_angle():
    # at exactly its own angle the estimate cannot decide: the exact comparison (strict <) says no
    angle = vertex_angle(4.0, 3.0, 0.0, 0.0, 4.0, 0.0)
    assert not vertex_angle_below(4.0, 3.0, 0.0, 0.0, 4.0, 0.0, angle, math.cos(math.radians(angle)))
    assert vertex_angle_below(4.0, 3.0, 0.0, 0.0, 4.0, 0.0, math.nextafter(angle, 180.0),
                              math.cos(math.radians(angle)))
    assert not vertex_angle_below(0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 1.0)  # a degenerate ray: angle 0, not < 0


def test_kick_rate_and_turn_inertia():
    # ball 0.7 m ahead at 90 deg: 0.027 (1 - 0.25 * 90/180 - 0.25 (0.7 - 0.385)/0.7) = 0.027 * 0.7625
    assert kick_rate(0.0, 0.0, 0.0, 0.0, 0.7, KP) == pytest.approx(0.027 * 0.7625)
    # 30 deg at speed 0.5: 30 * (1 + 5 * 0.5) = 105; 60 deg at 0.5 -> 210, clipped to 180
    assert turn_moment(30.0, 0.5, KP) == pytest.approx(105.0)
    assert turn_moment(60.0, 0.5, KP) == pytest.approx(180.0)


@pytest.mark.parametrize("dist, n, v0", [(10.0, 7, 1.85), (20.0, 12, 2.52)])
def test_pass_initial_speed(dist, n, v0):
    # n = round(log(dist (1/0.94 - 1)/1.2 + 1) / log(1/0.94)): 10 m -> round(6.89) = 7, 1.2/0.94^7 = 1.850;
    # 20 m -> round(11.71) = 12, 1.2/0.94^12 = 2.522
    got_n, got_v0 = pass_initial_speed(dist, 1.2, KP.ball_decay)
    assert got_n == n
    assert got_v0 == pytest.approx(v0, abs=0.005)


def test_hold_ball_kicks_ball_0875_m_ahead_of_predicted_position():
    # keeper 1 at (0, 0) moving (0.2, 0), body 0; ball still at (0.5, 0.3); takers > 5 m away, so the
    # desired direction is 0. Ball not at the 0.7 m spot ((0.7, 0) is 0.36 m away) -> kick close to body:
    # target = (0.2, 0) + 0.875 (1, 0) = (1.075, 0), 0.3 + 0.085 + 0.7 * 0.7 = 0.875 m from my next position.
    # kick vector (0.575, -0.3), |.| = 0.64856; rate = 0.027 (1 - 0.25 * 30.964/180 - 0.25 * 0.19806/0.7)
    # = 0.023929 -> power 27.10
    bel = belief([[0.5, 0.3], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1,
                 vel=[[0, 0], [0.2, 0.0], [0, 0], [0, 0], [0, 0], [0, 0]])
    code, power, kick_dir = hold_ball(bel, 0, CFG.hold_ratio_keeper, KP, CFG)
    assert code == CMD_KICK
    assert power == pytest.approx(27.10, abs=0.01)
    rate = kick_rate(0.0, 0.0, 0.0, 0.5, 0.3, KP)
    bx, by, _, _ = ball_after_kick(0.5, 0.3, 0.0, 0.0, rate, power, kick_dir, 0.0, KP)
    assert (bx, by) == pytest.approx((1.075, 0.0), abs=1e-9)
    assert math.hypot(bx - 0.2, by) == pytest.approx(0.875)


def test_hold_ball_turns_away_from_a_close_taker():
    # taker at (1.5, 0) with body 180 next to the ball (0.6, 0): phi = dir(taker -> me) = 180;
    # normalize(180 - 180) = 0 is not > 0, so s = +1 and the desired direction is 180 + 45 = -135 deg.
    # target = (0, 0) + 0.875 (cos -135, sin -135) = (-0.6187, -0.6187)
    bel = belief([[0.6, 0.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0], [1.5, 0.0], [9.0, -9.0]], 1,
                 body=[0, 0, 0, 0, 180, 180])
    code, power, kick_dir = hold_ball(bel, 0, CFG.hold_ratio_keeper, KP, CFG)
    assert code == CMD_KICK
    rate = kick_rate(0.0, 0.0, 0.0, 0.6, 0.0, KP)
    bx, by, _, _ = ball_after_kick(0.6, 0.0, 0.0, 0.0, rate, power, kick_dir, 0.0, KP)
    assert (bx, by) == pytest.approx((-0.875 / math.sqrt(2), -0.875 / math.sqrt(2)), abs=1e-9)


def test_taker_hold_ratio_keeps_ball_0595_m_from_body():
    # 0.3 + 0.085 + 0.7 * 0.3 = 0.595 m straight ahead of a still taker
    bel = belief([[0.5, 0.0], [-9.0, 0.0], [-9.0, 9.0], [-9.0, -9.0], [0.0, 0.0], [9.0, -9.0]], 4)
    code, power, kick_dir = kick_close_to_body(bel, 0, 0.0, CFG.hold_ratio_taker, KP, CFG)
    assert code == CMD_KICK
    rate = kick_rate(0.0, 0.0, 0.0, 0.5, 0.0, KP)
    bx, by, _, _ = ball_after_kick(0.5, 0.0, 0.0, 0.0, rate, power, kick_dir, 0.0, KP)
    assert (bx, by) == pytest.approx((0.595, 0.0), abs=1e-9)


@pytest.mark.parametrize("taker, expected", [([-1.5, 1.5], (CMD_KICK, 100.0, 180.0)),
                                             ([9.0, 9.0], (CMD_KICK, 91.40, 0.0))])
def test_pass_needing_more_than_105_power_repositions_unless_pressed(taker, expected):
    # ball 0.9 m behind keeper 1 (body 0): rate = 0.027 (1 - 0.25 - 0.25 (0.9 - 0.385)/0.7) = 0.015284.
    # PassBall-1 to keeper 2, 10 m from the ball: v0 = 1.2/0.94^7 = 1.8503 -> power 121.06, in (105, 130].
    # A taker 1.62 m from the ball -> pass anyway (one kick cannot: full power aligned, 180 deg);
    # nobody within 2 m -> reposition in front: 0.3 + 0.085 + 0.7 * 0.16 = 0.497 m ahead,
    # kick (1.397, 0) -> power 1.397 / 0.015284 = 91.40 at 0 deg
    bel = belief([[-0.9, 0.0], [0.0, 0.0], [-10.9, 0.0], [9.0, 9.0], taker, [9.0, -9.0]], 1)
    code, power, kick_dir = pass_ball(bel, 0, 1, KP, CFG)
    assert code == expected[0]
    assert power == pytest.approx(expected[1], abs=0.01)
    assert abs(normalize_angle(kick_dir - expected[2])) < 1e-9


def test_go_to_point_dashes_within_7_degrees():
    # target (10, 1) from a still player facing 0: atan(0.1) = 5.71 deg < 7 -> dash; 10 m in one cycle
    # needs 10 m/cycle, capped at 1.2 -> 1.2/0.006 = 200, clipped to 100
    bel = belief([[-5.0, 0.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1)
    assert go_to_point(bel, 0, 10.0, 1.0, KP, CFG) == (CMD_DASH, 100.0, 0.0)


def test_go_to_point_turns_beyond_7_degrees():
    # target (10, 2): atan(0.2) = 11.31 deg > 7; a still player needs one turn -> moment 11.31 (1 + 5 * 0)
    bel = belief([[-5.0, 0.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1)
    code, moment, _ = go_to_point(bel, 0, 10.0, 2.0, KP, CFG)
    assert code == CMD_TURN
    assert moment == pytest.approx(math.degrees(math.atan(0.2)))


def test_go_to_point_brakes_when_three_turns_are_needed():
    # moving at 0.4 m/cycle along 0 deg, target (-10, 0.5) behind: reference (0.667, 0), angle 177.3 deg.
    # turns: at v = 0.4 at most 180/3 = 60 deg; at 0.16, 180/1.8 = 100 deg; the rest (17.3) at 0.064
    # -> 3 turns -> brake: dash power (0 - 0.4)/(0.006 * 1) = -66.67
    bel = belief([[-5.0, 5.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1,
                 vel=[[0, 0], [0.4, 0.0], [0, 0], [0, 0], [0, 0], [0, 0]])
    code, power, _ = go_to_point(bel, 0, -10.0, 0.5, KP, CFG)
    assert code == CMD_DASH
    assert power == pytest.approx(-0.4 / 0.006)


def test_decay_sums_are_the_geometric_sums_to_the_horizon():
    # classic player_decay 0.4: 1 + 0.4 + ... + 0.4^(k-1) = (1 - 0.4^k) / 0.6: 0, 1, 1.4, 1.56, ...; the
    # table holds geometric_sum's own numbers (the travel simulations read it instead), k = 0..30
    sums = decay_sums(KP, CFG)
    assert sums.shape == (31,)
    assert sums[:4] == pytest.approx([0.0, 1.0, 1.4, 1.56], abs=1e-15)
    assert list(sums) == [geometric_sum(KP.player_decay, float(k)) for k in range(31)]
    slower = dataclasses.replace(parameter_set("classic"), player_decay=0.5).kernel()  # another decay
    assert list(decay_sums(slower, CFG)[:4]) == [0.0, 1.0, 1.5, 1.75]


def test_longest_run_is_full_dashes_from_the_current_speed():
    # classic: a full dash adds a = 100 x 0.006 = 0.6, the speed decays by 0.4; from rest the steps are
    # 0.6, 0.84, 0.936 (sum 2.376 = 3 x 1.0 + (0.6 - 1.0)(1 + 0.4 + 0.16)), where the cap alone allows 3.6
    assert _longest_run(0.0, 3, 1.0, SUMS, KP) == pytest.approx(2.376, abs=1e-12)
    assert _longest_run(0.0, 0, 1.0, SUMS, KP) == 0.0
    # at 0.5 m/cycle: steps 1.1, 1.04, 1.016 (sum 3.156); at effort 0.5 (a = 0.3): 0.8, 0.62, 0.548
    assert _longest_run(0.5, 3, 1.0, SUMS, KP) == pytest.approx(3.156, abs=1e-12)
    assert _longest_run(0.5, 3, 0.5, SUMS, KP) == pytest.approx(1.968, abs=1e-12)
    # at 2 m/cycle (beyond the 1.2 cap): a turn keeps the step at 2, then 0.8 + 0.6 = 1.4, 0.56 + 0.6 = 1.16
    # (a sum of 4.56); the cap alone allows 3 x 2 = 6
    assert _longest_run(2.0, 3, 1.0, SUMS, KP) == pytest.approx(4.56, abs=1e-12)


def test_no_commands_outrun_the_longest_run():
    # random turns and dashes (any power, any body) never cover more ground than the bound; full dashes
    # along the velocity reach it
    rng = np.random.default_rng(3)
    for _ in range(500):
        speed, n = rng.uniform(0.0, 1.5), int(rng.integers(1, 12))
        x, y, vx, vy, body = 0.0, 0.0, speed, 0.0, rng.uniform(-180.0, 180.0)
        for _ in range(n):
            if rng.random() < 0.3:
                x, y, vx, vy, body = player_step(x, y, vx, vy, body, 1.0, CMD_TURN, rng.uniform(-180, 180), KP)
            else:
                x, y, vx, vy, body = player_step(x, y, vx, vy, body, 1.0, CMD_DASH, rng.uniform(-100, 100), KP)
        assert math.hypot(x, y) <= _longest_run(speed, n, 1.0, SUMS, KP) + 1e-12
        x, y, vx, vy, body = 0.0, 0.0, speed, 0.0, 0.0
        for _ in range(n):
            x, y, vx, vy, body = player_step(x, y, vx, vy, body, 1.0, CMD_DASH, 100.0, KP)
        assert x == pytest.approx(_longest_run(speed, n, 1.0, SUMS, KP), abs=1e-12) or speed + 0.6 > 1.2


def test_interception_point_of_a_ball_rolling_towards_me():
    # ball from (-10, 0) at 1.5 m/cycle towards a keeper at (0, 0) facing it (body 180).
    # ball after i cycles: x_i = -10 + 25 (1 - 0.94^i): x_4 = -4.519, x_5 = -3.348.
    # full dashes cover 0.6, 0.84, 0.936, 0.974 (sum 3.350 after 4 cycles, 4.339 after 5): within
    # 1.085 of x_4 needs 3.434 m (no), of x_5 needs 2.263 m (yes) -> i = 5
    bel = belief([[-10.0, 0.0], [0.0, 0.0], [9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1,
                 vel=[[1.5, 0.0], [0, 0], [0, 0], [0, 0], [0, 0], [0, 0]], body=[0, 180, 0, 0, 0, 0])
    mem = new_memory(1, seed_streams(0, 1))
    i, x, y = interception_point(bel, 0, mem, SUMS, KP, CFG, UNKNOWN_FIRST)
    assert i == 5
    assert (x, y) == pytest.approx((-10.0 + 25.0 * (1.0 - 0.94**5), 0.0))
    # far from it (i >= 3): move there, a full dash since 3.35 m in 5 cycles needs more than 1.2 m/cycle
    assert intercept(bel, 0, new_memory(1, seed_streams(0, 1)), SUMS, KP, CFG, UNKNOWN_FIRST) == (CMD_DASH, 100.0, 0.0)


def test_fastest_keeper_to_a_rolling_ball():
    # same ball; keeper 1 (0, 0) facing it reaches it after 5 cycles (above); keeper 2 at (0, -6) must
    # first cover 4.9 m sideways (>= 6 cycles) and keeper 3 at (9, 0) is behind keeper 1
    bel = belief([[-10.0, 0.0], [0.0, 0.0], [0.0, -6.0], [9.0, 0.0]] + FAR_TAKERS, 2,
                 vel=[[1.5, 0.0], [0, 0], [0, 0], [0, 0], [0, 0], [0, 0]], body=[0, 180, 90, 180, 0, 0])
    assert fastest_to_ball(bel, 0, 1, 3, SUMS, KP, CFG) == (1, 5)


def test_close_intercept_dashes_when_an_opponent_is_near():
    # keeper at (0, 0) facing 0, ball at rest at (1.5, 0), a taker 2.2 m away. The body line meets the
    # circle of radius 0.3 + 0.085 + 0.7/6 = 0.5017 around the ball at x = 0.998 and 2.002; the forward
    # one first: any power above 100 is cut to 100, which moves me 0.6 m, 0.9 m < 0.95 x 1.085 = 1.031
    # from the ball -> with the opponent within 3 m the dash is taken at once
    bel = belief([[1.5, 0.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0], [2.0, 1.0], [9.0, -9.0]], 1)
    assert close_intercept(bel, 0, KP, CFG) == (True, CMD_DASH, 100.0)


@pytest.mark.parametrize("me, expected_moment", [(1, -90.0), (4, 90.0)])
def test_close_intercept_turns_to_its_own_forward_direction(me, expected_moment):
    # a still player facing 90 with the ball at rest 0.8 m to its right (< 0.8 x 1.085 = 0.868), nobody
    # within 3 m: turning to "global 0" keeps the ball, so it turns. The keeper's 0 deg is the server's
    # 0; the taker's (the right-hand team, whose C++ frame is mirrored) is the server's 180.
    pos = [[0.8, 0.0], [-9.0, -9.0], [-9.0, 0.0], [0.0, 9.0], [9.0, -9.0], [9.0, 9.0]]
    pos[me] = [0.0, 0.0]
    body = [0.0] * 6
    body[me] = 90.0
    bel = belief(pos, me, body=body)
    assert forward_angle(bel, 0) == (0.0 if me == 1 else 180.0)
    assert close_intercept(bel, 0, KP, CFG) == (True, CMD_TURN, pytest.approx(expected_moment))


def test_intercept_move_turns_its_back_to_a_close_point():
    # moving at 0.5 m/cycle along body 0, target (0, 2) to be reached in 2 cycles. Rolled out 2 cycles:
    # q = (0.7, 0); the point is 2.119 m away (< 2.5) at 109.29 deg, 2.0 m off the body line (> 0.9 x
    # 1.085). Inertia 1 + 5 x 0.5 limits the first turn to 51.43 deg (then 57.86 at speed 0.2): two turns,
    # so the player turns its back instead: -70.71 deg wanted, moment -247.5 cut to -180, body -51.43 ->
    # the point is 2.119 sin(160.72 deg) = 0.700 m off the line (< 0.9 x 1.085): turn with moment -180
    assert intercept_move(0.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 2.0, 2.0, KP, CFG) == (CMD_TURN, -180.0)
    # arriving in 4 cycles the rule does not apply: the turn goes towards the point (moment cut to 180)
    assert intercept_move(0.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 2.0, 4.0, KP, CFG) == (CMD_TURN, 180.0)


def test_intercept_move_dashes_backwards_as_the_cpp_players_believe_they_can():
    # a still player facing 0, the point 1.5 m straight behind it, 2 cycles away: within the 2.5 m back
    # distance and on the body line -> dash backwards, -1.5 / (1 + 0.4) = -1.0714 m/cycle over 0.006 ->
    # -178.6, cut to min_power -100. With CURRENT too (min_dash_power 0, so the server ignores it): the
    # players believe in min_power, as keepaway-0.6's do
    assert intercept_move(0.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.5, 0.0, 2.0, KP, CFG) == (CMD_DASH, -100.0)
    current = parameter_set("current").kernel()
    assert intercept_move(0.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.5, 0.0, 2.0, current, CFG) == (CMD_DASH, -100.0)


def test_a_player_stuck_dashing_backwards_turns_round():
    # CURRENT: a still keeper facing 0 with a still ball 1.5 m straight behind it dashes backwards (above),
    # which the server ignores, so nothing changes: after stuck_dash_limit (30) such dashes standing still
    # the next intercept turns to the ball instead (moment 180), and the count starts again
    current = parameter_set("current").kernel()
    pos = np.array([[-1.5, 0.0], [0.0, 0.0], [9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, dtype=float)
    sums = decay_sums(current, CFG)
    mem = new_memory(1, seed_streams(0, 1))
    commands = []
    for t in range(32):
        bel = belief_from_truth(pos, np.zeros_like(pos), np.zeros(6), np.zeros(6), 1, t, 3, 2)
        commands.append(intercept(bel, 0, mem, sums, current, CFG, UNKNOWN_FIRST))
    assert commands[:30] == [(CMD_DASH, -100.0, 0.0)] * 30
    assert commands[30] == (CMD_TURN, 180.0, 0.0)
    assert commands[31] == (CMD_DASH, -100.0, 0.0) and mem.stuck_dashes[0] == 1
    # moving resets the count
    vel = np.zeros_like(pos)
    vel[1] = (0.05, 0.0)
    intercept(belief_from_truth(pos, vel, np.zeros(6), np.zeros(6), 1, 32, 3, 2), 0, mem, sums, current, CFG,
              UNKNOWN_FIRST)
    assert mem.stuck_dashes[0] == 0


def test_two_takers_dashing_backwards_at_a_held_ball_do_not_deadlock():
    # Always hold, CURRENT, arena seed 85: in episode 9 both takers stood 1.4-2.0 m from a ball the keeper
    # held behind them, sending dash -100 every cycle, for ever, until _unstuck (docs/design.md, "The players' skills")
    game = EmbeddedGame(ArenaSpec(parameter_set("current"), seed=85, pass_policy="hold"))
    ends = []
    while len(ends) < 10 and game.arena.cycle < 2000:
        record = game.cycle()
        if record is not None:
            ends.append(record.end_cycle)
    assert len(ends) == 10


def _run_intercept(ball_pos, ball_vel, me_pos, me_body, cycles):
    """Closed loop on a noise-free world: the keeper intercepts each cycle; returns the first cycle in
    which the ball is kickable (or None)."""
    pos = np.array([ball_pos, me_pos, [9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, dtype=float)
    vel = np.zeros_like(pos)
    vel[0] = ball_vel
    body = np.zeros(6)
    body[1] = me_body
    mem = new_memory(1, seed_streams(0, 1))
    for t in range(cycles):
        if math.dist(pos[0], pos[1]) < KP.player_size + KP.kickable_margin + KP.ball_size:
            return t
        bel = belief_from_truth(pos, vel, body, np.zeros(6), 1, t, 3, 2)
        code, a1, _ = intercept(bel, 0, mem, SUMS, KP, CFG, UNKNOWN_FIRST)
        x, y, vx, vy, b = player_step(pos[1, 0], pos[1, 1], vel[1, 0], vel[1, 1], body[1], 1.0, code, a1, KP)
        pos[1], vel[1], body[1] = (x, y), (vx, vy), b
        pos[0] += vel[0]
        vel[0] *= KP.ball_decay
    return None


def test_intercept_gets_a_ball_rolling_towards_me():
    # the interception point above is 5 cycles away; the closed loop reaches the ball by then
    assert _run_intercept([-10.0, 0.0], [1.5, 0.0], [0.0, 0.0], 180.0, 30) <= 5


def test_intercept_gets_a_ball_rolling_past_me():
    # the ball passes 3 m beside the keeper (body 90 faces the ball's line, +y). It crosses x = 0 when
    # 25 (1 - 0.94^i) = 10, i = 8.3; the keeper needs 3 - 1.085 = 1.9 m sideways (3 dashes: 2.38 m), so he
    # must have it before the ball has passed him
    t = _run_intercept([-10.0, 3.0], [1.5, 0.0], [0.0, 0.0], 90.0, 30)
    assert t is not None and t <= 8


def test_search_turns_60_degrees_towards_the_last_ball_side():
    # ball last seen at relative angle -90 (up, y < 0): turn -60 deg (still player: moment = angle)
    bel = belief([[0.0, -5.0], [0.0, 0.0], [-9.0, 0.0], [0.0, 9.0]] + FAR_TAKERS, 1)
    mem = new_memory(1, seed_streams(0, 1))
    code, moment, _ = search_ball(bel, 0, mem, KP, CFG)
    assert code == CMD_TURN
    assert moment == pytest.approx(-60.0)
