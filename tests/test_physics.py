"""Hand-computed checks of every physics formula (spec `server-physics.md` 2, 3; traces README hand checks)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from keepaway.protocol.params import parameter_set
from keepaway.server.physics import (
    apply_commands,
    dash_direction_rate,
    kick_possible,
    move_objects,
    physics_step,
    place_object,
    resolve_collisions,
    update_stamina,
)
from keepaway.core.rng import seed_streams
from keepaway.core.objects import BALL, CMD_CATCH, CMD_DASH, CMD_KICK, CMD_MOVE, CMD_TURN
from keepaway.server.world import (
    COLLIDED_BALL,
    COLLIDED_PLAYER,
    COUNT_DASH,
    COUNT_KICK,
    COUNT_TURN,
    COUNT_TURN_NECK,
    Commands,
    World,
    new_world,
)

# Zero-noise sets, as the traces use them (player_rand = ball_rand = kick_rand = 0).
CURRENT = parameter_set("current", keepaway_launch=False, player_rand=0.0, ball_rand=0.0, kick_rand=0.0)
CLASSIC = parameter_set("classic", keepaway_launch=False, player_rand=0.0, ball_rand=0.0)
PLAYER = 1


def arena(params=CURRENT, n_keepers=1, n_takers=1, batch=1, seed=0):
    """Keeper 1 enabled at the origin with body 0, the ball parked at (30, 30), everyone else disabled."""
    w = new_world(params, n_keepers, n_takers, batch, seed)
    w.enabled[:, PLAYER] = True
    w.pos[:, PLAYER] = 0.0
    w.pos[:, BALL] = (30.0, 30.0)
    return w, Commands.empty(batch, w.n_objects), params.kernel()


def order(c: Commands, i: int, code: int, arg1: float = 0.0, arg2: float = 0.0) -> None:
    c.main[:, i] = code
    c.arg1[:, i] = arg1
    c.arg2[:, i] = arg2


def step_once(w: World, c: Commands, kp) -> None:
    physics_step(w, c, kp)
    c.clear()


# --- dash -----------------------------------------------------------------------------------------------

def test_dash_from_rest_moves_0_6_and_keeps_0_24():
    # a = effort 1 * power 100 * rate 1 * 0.006 = 0.6; v = 0.6; x = 0.6; stored v = 0.6 * 0.4 = 0.24.
    # stamina 8000 - 100 = 7900, + min(45, 8000 - 7900) = 7945; capacity 130600 - 45 = 130555.
    w, c, kp = arena()
    order(c, PLAYER, CMD_DASH, 100.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER] == pytest.approx([0.6, 0.0], abs=1e-12)
    assert w.vel[0, PLAYER] == pytest.approx([0.24, 0.0], abs=1e-12)
    assert w.stamina[0, PLAYER] == pytest.approx(7945.0)
    assert w.capacity[0, PLAYER] == pytest.approx(130555.0)
    assert w.counts[0, PLAYER, COUNT_DASH] == 1
    assert w.time[0] == 1


def test_dashing_converges_to_stored_speed_0_4():
    # v' = 0.4 * (v + 0.6): fixed point 0.4, pre-decay speed 1.0 < player_speed_max 1.05 (never capped).
    w, c, kp = arena()
    order(c, PLAYER, CMD_DASH, 100.0)
    for _ in range(40):
        physics_step(w, c, kp)
    assert w.vel[0, PLAYER, 0] == pytest.approx(0.4, abs=1e-12)


def test_player_and_ball_decay_sequences():
    # Player after one dash: 0.24, then x0.4 per cycle: 0.096, 0.0384. Ball from (-20,-10) with v=(2,1):
    # v_n = 0.94^n (2,1) and x_40 = -20 + 2 (1 - 0.94^40) / 0.06.
    w, c, kp = arena()
    place_object(0, w, BALL, -20.0, -10.0, 2.0, 1.0, math.nan, kp)
    order(c, PLAYER, CMD_DASH, 100.0)
    step_once(w, c, kp)
    step_once(w, c, kp)
    assert w.vel[0, PLAYER, 0] == pytest.approx(0.096, abs=1e-12)
    step_once(w, c, kp)
    assert w.vel[0, PLAYER, 0] == pytest.approx(0.0384, abs=1e-12)
    for _ in range(37):
        step_once(w, c, kp)
    assert w.vel[0, BALL] == pytest.approx([2.0 * 0.94**40, 0.94**40], rel=1e-12)
    assert w.pos[0, BALL, 0] == pytest.approx(-20.0 + 2.0 * (1.0 - 0.94**40) / 0.06, rel=1e-12)


def test_speed_cap_applies_only_in_a_step_with_acceleration():
    # Trainer speed 1.5 without a dash: not capped, x = 1.5, stored 1.5 * 0.4 = 0.6.
    w, c, kp = arena()
    place_object(0, w, PLAYER, 0.0, 0.0, 1.5, 0.0, math.nan, kp)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER, 0] == pytest.approx(1.5)
    assert w.vel[0, PLAYER, 0] == pytest.approx(0.6)
    # With a dash: 1.5 + 0.6 = 2.1 is capped to 1.05: x = 1.5 + 1.05, stored 1.05 * 0.4 = 0.42.
    place_object(0, w, PLAYER, 1.5, 0.0, 1.5, 0.0, math.nan, kp)
    order(c, PLAYER, CMD_DASH, 100.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER, 0] == pytest.approx(2.55)
    assert w.vel[0, PLAYER, 0] == pytest.approx(0.42)
    # A ball at 4.0 > ball_speed_max 3.0 rolls uncapped: x = -30 + 4, stored 4 * 0.94 = 3.76.
    place_object(0, w, BALL, -30.0, 20.0, 4.0, 0.0, math.nan, kp)
    step_once(w, c, kp)
    assert w.pos[0, BALL, 0] == pytest.approx(-26.0)
    assert w.vel[0, BALL, 0] == pytest.approx(3.76)


def test_current_dash_direction_rates():
    kp = CURRENT.kernel()
    assert dash_direction_rate(180.0, kp) == pytest.approx(0.7)
    assert dash_direction_rate(90.0, kp) == pytest.approx(0.4)
    assert dash_direction_rate(0.0, kp) == pytest.approx(1.0)
    assert dash_direction_rate(-37.0, kp) == pytest.approx(0.4 + 0.6 * (1.0 - 37.0 / 90.0))


def test_current_dash_direction_is_snapped_to_the_angle_step():
    # -37.4 rounds to -37 (dash_angle_step 1): a = 0.6 * (0.4 + 0.6 * 53/90) = 0.452 at -37 degrees.
    w, c, kp = arena()
    order(c, PLAYER, CMD_DASH, 100.0, -37.4)
    step_once(w, c, kp)
    a = 0.6 * (0.4 + 0.6 * (1.0 - 37.0 / 90.0))
    expected = [a * math.cos(math.radians(-37.0)), a * math.sin(math.radians(-37.0))]
    assert w.pos[0, PLAYER] == pytest.approx(expected, abs=1e-12)
    assert w.body[0, PLAYER] == 0.0


def test_current_negative_dash_is_clamped_to_zero_but_counted():
    # min_dash_power = 0 from 17.0: no motion, no cost (stamina stays at its maximum), dash counter + 1.
    w, c, kp = arena()
    order(c, PLAYER, CMD_DASH, -100.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER] == pytest.approx([0.0, 0.0], abs=0.0)
    assert w.stamina[0, PLAYER] == 8000.0
    assert w.counts[0, PLAYER, COUNT_DASH] == 1


def test_classic_negative_dash_costs_twice_and_pushes_backwards():
    # CLASSIC: power -100 costs 200: 4000 - 200 + 45 = 3845; a = 0.6 backwards, so x = -0.6.
    w, c, kp = arena(CLASSIC)
    order(c, PLAYER, CMD_DASH, -100.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER] == pytest.approx([-0.6, 0.0], abs=1e-12)
    assert w.stamina[0, PLAYER] == pytest.approx(3845.0)


def test_classic_dash_has_no_direction():
    # min_dash_angle = max_dash_angle = 0: (dash 100 90) runs straight ahead at full rate.
    w, c, kp = arena(CLASSIC)
    order(c, PLAYER, CMD_DASH, 100.0, 90.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER] == pytest.approx([0.6, 0.0], abs=1e-12)


def test_dash_uses_at_most_stamina_plus_extra():
    # stamina 30 + extra 50 = 80 < 100: power 80, a = 0.48, stamina floored at 0, then + 45.
    w, c, kp = arena()
    w.stamina[0, PLAYER] = 30.0
    order(c, PLAYER, CMD_DASH, 100.0)
    step_once(w, c, kp)
    assert w.pos[0, PLAYER, 0] == pytest.approx(0.48)
    # recovery and effort drop first (0 <= 2400): 45 * 0.998 = 44.91.
    assert w.stamina[0, PLAYER] == pytest.approx(44.91)


# --- turn and neck ----------------------------------------------------------------------------------------

def test_turn_under_inertia():
    # 90 / (1 + 5 * 0.197952) = 45.2316 with no noise; effective only after the step.
    w, c, kp = arena()
    w.vel[0, PLAYER] = (0.197952, 0.0)
    order(c, PLAYER, CMD_TURN, 90.0)
    apply_commands(0, w, c, kp)
    assert w.body[0, PLAYER] == 0.0
    assert w.body_pending[0, PLAYER] == pytest.approx(45.2316, abs=1e-4)
    move_objects(0, w, kp)
    assert w.body[0, PLAYER] == pytest.approx(90.0 / (1.0 + 5.0 * 0.197952))
    assert w.counts[0, PLAYER, COUNT_TURN] == 1


def test_turn_moment_is_clamped_and_the_angle_normalised():
    # turn 300 -> 180 at rest; body 170 + 180 = 350 -> -10.
    w, c, kp = arena()
    place_object(0, w, PLAYER, 0.0, 0.0, 0.0, 0.0, 170.0, kp)
    order(c, PLAYER, CMD_TURN, 300.0)
    step_once(w, c, kp)
    assert w.body[0, PLAYER] == pytest.approx(-10.0)


def test_turn_noise_stays_within_player_rand():
    # (1 + U(-0.1, 0.1)) * 60 at rest: every arena ends in [54, 66] and the draws spread over it.
    params = parameter_set("current", keepaway_launch=False)
    w, c, kp = arena(params, batch=500, seed=3)
    order(c, PLAYER, CMD_TURN, 60.0)
    step_once(w, c, kp)
    body = w.body[:, PLAYER]
    assert body.min() >= 54.0 and body.max() <= 66.0
    assert body.min() < 55.0 and body.max() > 65.0


def test_neck_turns_are_clamped_to_the_neck_range():
    w, c, kp = arena()
    c.has_neck[0, PLAYER] = True
    c.neck[0, PLAYER] = 120.0
    step_once(w, c, kp)
    assert w.neck[0, PLAYER] == 90.0
    c.has_neck[0, PLAYER] = True
    c.neck[0, PLAYER] = -200.0  # moment clamped to -180: 90 - 180 = -90
    apply_commands(0, w, c, kp)
    assert w.neck[0, PLAYER] == 90.0  # pending until the step
    assert w.neck_pending[0, PLAYER] == -90.0
    assert w.counts[0, PLAYER, COUNT_TURN_NECK] == 2


# --- kick -------------------------------------------------------------------------------------------------

def test_kick_ahead_effective_power():
    # d = 0.5 - 0.385 = 0.115: eff = 100 * 0.027 * (1 - 0.25 * 0.115 / 0.7) = 2.58911;
    # x = 0.5 + 2.58911 = 3.08911, v = 2.58911 * 0.94 = 2.43376.
    w, c, kp = arena()
    place_object(0, w, BALL, 0.5, 0.0, 0.0, 0.0, math.nan, kp)
    order(c, PLAYER, CMD_KICK, 100.0, 0.0)
    step_once(w, c, kp)
    eff = 2.7 * (1.0 - 0.25 * 0.115 / 0.7)
    assert eff == pytest.approx(2.58911, abs=1e-5)
    assert w.pos[0, BALL] == pytest.approx([0.5 + eff, 0.0], abs=1e-12)
    assert w.vel[0, BALL] == pytest.approx([eff * 0.94, 0.0], abs=1e-12)
    assert w.counts[0, PLAYER, COUNT_KICK] == 1
    assert w.kicked[0, PLAYER]


def test_kick_from_behind_loses_a_quarter_for_the_angle():
    # dir_diff 180: eff = 2.7 * (1 - 0.25 - 0.25 * 0.215 / 0.7) = 1.81768; x = -0.6 + eff = 1.21768.
    w, c, kp = arena()
    place_object(0, w, BALL, -0.6, 0.0, 0.0, 0.0, math.nan, kp)
    order(c, PLAYER, CMD_KICK, 100.0, 0.0)
    step_once(w, c, kp)
    eff = 2.7 * (1.0 - 0.25 - 0.25 * 0.215 / 0.7)
    assert w.pos[0, BALL, 0] == pytest.approx(-0.6 + eff, abs=1e-12)
    assert w.pos[0, BALL, 0] == pytest.approx(1.21768, abs=1e-5)


def test_kick_direction_is_relative_to_the_body():
    # body 90, kick 100 at -90: global direction 0; the ball is 0.5 m along the body (dir_diff 0).
    w, c, kp = arena()
    place_object(0, w, PLAYER, 0.0, 0.0, 0.0, 0.0, 90.0, kp)
    place_object(0, w, BALL, 0.0, 0.5, 0.0, 0.0, math.nan, kp)
    order(c, PLAYER, CMD_KICK, 100.0, -90.0)
    step_once(w, c, kp)
    eff = 2.7 * (1.0 - 0.25 * 0.115 / 0.7)
    assert w.pos[0, BALL] == pytest.approx([eff, 0.5], abs=1e-12)


def test_ball_beyond_kickable_distance_is_not_kicked():
    # kickable distance 0.3 + 0.7 + 0.085 = 1.085
    w, c, kp = arena()
    place_object(0, w, BALL, 1.084, 0.0, 0.0, 0.0, math.nan, kp)
    assert kick_possible(0, w, PLAYER, kp)
    place_object(0, w, BALL, 1.086, 0.0, 0.0, 0.0, math.nan, kp)
    assert not kick_possible(0, w, PLAYER, kp)
    order(c, PLAYER, CMD_KICK, 100.0, 0.0)
    step_once(w, c, kp)
    assert w.pos[0, BALL] == pytest.approx([1.086, 0.0], abs=0.0)
    assert w.counts[0, PLAYER, COUNT_KICK] == 0
    assert w.kicked[0, PLAYER]  # rcssserver marks the kick attempt (KICK state) even when it fails


def test_kick_adds_to_the_current_ball_velocity():
    # v = 0.5 + eff(50) = 0.5 + 1.35 * (1 - 0.25 * 0.115 / 0.7) = 1.794554; x = 0.5 + v.
    w, c, kp = arena()
    place_object(0, w, BALL, 0.5, 0.0, 0.5, 0.0, math.nan, kp)
    order(c, PLAYER, CMD_KICK, 50.0, 0.0)
    step_once(w, c, kp)
    v = 0.5 + 1.35 * (1.0 - 0.25 * 0.115 / 0.7)
    assert w.pos[0, BALL, 0] == pytest.approx(0.5 + v, abs=1e-12)
    assert w.vel[0, BALL, 0] == pytest.approx(0.94 * v, abs=1e-12)


def test_two_kicks_add_up_and_are_capped_at_ball_accel_max():
    # Two kickers push eff = 2.58911 along +x and +y: |a| = 3.66 > 2.7, scaled to 2.7 at 45 degrees.
    w, c, kp = arena(n_keepers=2)
    w.enabled[0, 2] = True
    place_object(0, w, BALL, 0.5, 0.0, 0.0, 0.0, math.nan, kp)
    place_object(0, w, 2, 0.5, -0.5, 0.0, 0.0, 90.0, kp)
    order(c, PLAYER, CMD_KICK, 100.0, 0.0)
    order(c, 2, CMD_KICK, 100.0, 0.0)
    apply_commands(0, w, c, kp)
    eff = 2.7 * (1.0 - 0.25 * 0.115 / 0.7)
    assert w.acc[0, BALL] == pytest.approx([eff, eff], abs=1e-12)
    move_objects(0, w, kp)
    side = 2.7 / math.sqrt(2.0)
    assert w.pos[0, BALL] == pytest.approx([0.5 + side, side], abs=1e-12)


def test_move_and_catch_do_nothing_in_play_on():
    w, c, kp = arena()
    before = w.copy()
    order(c, PLAYER, CMD_MOVE, 10.0, 10.0)
    apply_commands(0, w, c, kp)
    order(c, PLAYER, CMD_CATCH, 0.0)
    apply_commands(0, w, c, kp)
    for got, expected in zip(w, before):
        np.testing.assert_array_equal(got, expected)


# --- noise ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["classic", "current"])
def test_movement_noise_is_bounded_by_rand_times_speed(name):
    # Ball at v = 1 (no acceleration): r = 0.05 * 1. CLASSIC: each axis in [-r, r]; CURRENT: |noise| <= r.
    params = parameter_set(name, keepaway_launch=False)
    w, c, kp = arena(params, batch=400, seed=5)
    w.pos[:, BALL] = 0.0
    w.vel[:, BALL] = (1.0, 0.0)
    move_objects_all(w, kp)
    noise = w.pos[:, BALL] - (1.0, 0.0)
    if name == "classic":
        assert np.abs(noise).max() <= 0.05
        assert np.abs(noise).max(axis=0).min() > 0.045  # both axes use the whole range
    else:
        assert np.hypot(noise[:, 0], noise[:, 1]).max() <= 0.05 + 1e-12
        assert np.abs(noise[:, 1]).max() > 0.045  # direction uniform over the circle


def move_objects_all(w: World, kp) -> None:
    for b in range(w.batch):
        move_objects(b, w, kp)


def test_classic_kick_noise_is_per_axis_kick_rand_times_power():
    # CLASSIC with kick_rand 0.1: r = 0.1 * 100 / 100 = 0.1 per axis around the exact kick.
    params = parameter_set("classic", keepaway_launch=False, player_rand=0.0, ball_rand=0.0, kick_rand=0.1)
    w, c, kp = arena(params, batch=300, seed=11)
    w.pos[:, BALL] = (0.5, 0.0)
    order(c, PLAYER, CMD_KICK, 100.0, 0.0)
    for b in range(w.batch):
        apply_commands(b, w, c, kp)
    noise = w.acc[:, BALL] - (2.7 * (1.0 - 0.25 * 0.115 / 0.7), 0.0)
    assert np.abs(noise).max() <= 0.1
    assert np.abs(noise).max(axis=0).min() > 0.09


# --- collisions -------------------------------------------------------------------------------------------

def test_ball_player_collision_separates_to_0_385_and_reverses_velocities():
    # e_collide trace, cycle 3: player at 1.44 (v 0.336) overlaps the ball at 1.5. Midpoint 1.47, each
    # moved 0.1925 (+1e-10) away: player 1.2775, ball 1.6625; velocities x -0.1.
    w, c, kp = arena()
    w.pos[0, BALL] = (1.5, 0.0)
    w.pos[0, PLAYER] = (1.44, 0.0)
    w.vel[0, PLAYER] = (0.336, 0.0)
    w.vel[0, BALL] = (0.2, 0.0)
    resolve_collisions(0, w, kp)
    assert w.pos[0, PLAYER, 0] == pytest.approx(1.2775, abs=1e-9)
    assert w.pos[0, BALL, 0] == pytest.approx(1.6625, abs=1e-9)
    assert w.pos[0, BALL, 0] - w.pos[0, PLAYER, 0] >= 0.385
    assert w.vel[0, PLAYER, 0] == pytest.approx(-0.0336)
    assert w.vel[0, BALL, 0] == pytest.approx(-0.02)
    assert w.collision[0, PLAYER] == COLLIDED_BALL


def test_player_player_collision_separates_to_0_6():
    # players 0.4 apart on a diagonal: midpoint kept, each 0.3 (+1e-10) from it; both flagged.
    w, c, kp = arena(n_keepers=2)
    w.enabled[0, 2] = True
    w.pos[0, PLAYER] = (0.0, 0.0)
    w.pos[0, 2] = (0.4 / math.sqrt(2.0), 0.4 / math.sqrt(2.0))
    w.vel[0, 2] = (0.5, 0.0)
    resolve_collisions(0, w, kp)
    mid = 0.2 / math.sqrt(2.0)
    off = 0.3 / math.sqrt(2.0)
    assert w.pos[0, PLAYER] == pytest.approx([mid - off, mid - off], abs=1e-9)
    assert w.pos[0, 2] == pytest.approx([mid + off, mid + off], abs=1e-9)
    assert w.vel[0, 2] == pytest.approx([-0.05, 0.0])
    assert w.collision[0, PLAYER] == COLLIDED_PLAYER and w.collision[0, 2] == COLLIDED_PLAYER


def test_disabled_players_do_not_collide_or_move():
    w, c, kp = arena()
    taker = 2
    w.pos[0, taker] = (0.1, 0.0)
    w.vel[0, taker] = (1.0, 0.0)
    physics_step(w, c, kp)
    assert w.pos[0, taker] == pytest.approx([0.1, 0.0], abs=0.0)
    assert w.pos[0, PLAYER] == pytest.approx([0.0, 0.0], abs=0.0)
    assert w.collision[0].sum() == 0


def test_trainer_player_move_onto_the_ball_collides_at_once():
    w, c, kp = arena()
    place_object(0, w, BALL, 0.1, 0.0, 0.0, 0.0, math.nan, kp)
    assert w.pos[0, BALL, 0] == 0.1  # a ball move alone does not run the collision routine
    place_object(0, w, PLAYER, 0.0, 0.0, 0.0, 0.0, 0.0, kp)
    assert w.pos[0, BALL, 0] - w.pos[0, PLAYER, 0] == pytest.approx(0.385, abs=1e-9)


def test_collision_flags_describe_the_last_step_only():
    w, c, kp = arena()
    w.collision[0, PLAYER] = COLLIDED_BALL
    physics_step(w, c, kp)
    assert w.collision[0, PLAYER] == 0


# --- stamina ----------------------------------------------------------------------------------------------

def stamina_after_update(params, stamina, effort=1.0, recovery=1.0, capacity=None):
    w, c, kp = arena(params)
    w.stamina[0, PLAYER] = stamina
    w.effort[0, PLAYER] = effort
    w.recovery[0, PLAYER] = recovery
    if capacity is not None:
        w.capacity[0, PLAYER] = capacity
    update_stamina(0, w, kp)
    return w.stamina[0, PLAYER], w.effort[0, PLAYER], w.recovery[0, PLAYER], w.capacity[0, PLAYER]


def test_effort_and_recovery_fall_at_the_thresholds():
    # 2400 = 0.3 * 8000: recovery 1 - 0.002, effort 1 - 0.005, stamina 2400 + 0.998 * 45 = 2444.91.
    stamina, effort, recovery, capacity = stamina_after_update(CURRENT, 2400.0)
    assert (stamina, effort, recovery) == pytest.approx((2444.91, 0.995, 0.998))
    assert capacity == pytest.approx(130600.0 - 44.91)
    # 2401 is above both thresholds: nothing falls.
    assert stamina_after_update(CURRENT, 2401.0)[1:3] == (1.0, 1.0)


def test_effort_and_recovery_stop_at_their_minimums():
    _, effort, recovery, _ = stamina_after_update(CURRENT, 100.0, effort=0.602, recovery=0.501)
    assert (effort, recovery) == (0.6, 0.5)


def test_effort_recovers_above_effort_inc_thr_in_current():
    # CURRENT: threshold 0.6 * 8000 = 4800.
    assert stamina_after_update(CURRENT, 4800.0, effort=0.9)[1] == pytest.approx(0.91)
    assert stamina_after_update(CURRENT, 4799.0, effort=0.9)[1] == 0.9


def test_classic_effort_bug_recovers_above_effort_dec_thr():
    # CLASSIC uses effort_dec_thr: 0.3 * 4000 = 1200, so effort grows at 1201 already.
    assert stamina_after_update(CLASSIC, 1201.0, effort=0.9)[1] == pytest.approx(0.91)
    assert stamina_after_update(CLASSIC, 1199.0, effort=0.9)[1] == pytest.approx(0.895)


def test_stamina_gain_is_limited_by_maximum_and_capacity():
    # Full stamina gains nothing and uses no capacity; a capacity of 10 limits the gain to 10.
    assert stamina_after_update(CURRENT, 8000.0)[0::3] == (8000.0, 130600.0)
    assert stamina_after_update(CURRENT, 7000.0, capacity=10.0)[0::3] == (7010.0, 0.0)
    assert stamina_after_update(CURRENT, 7000.0, capacity=0.0)[0] == 7000.0
    # CLASSIC has no capacity model: the gain is 45 and capacity stays at its -1 marker.
    assert stamina_after_update(CLASSIC, 3000.0)[0::3] == (3045.0, -1.0)


# --- determinism and batching -----------------------------------------------------------------------------

def noisy_run(seed: int, batch: int = 1, streams: np.ndarray | None = None) -> World:
    """20 noisy CURRENT cycles (kick, dashes, turns) from ``seed``, or from explicit per-arena streams."""
    params = parameter_set("current", keepaway_launch=False)
    w, c, kp = arena(params, batch=batch, seed=seed)
    if streams is not None:
        w.rng[:] = streams
    w.pos[:, BALL] = (0.5, 0.0)
    for t in range(20):
        c.clear()
        order(c, PLAYER, CMD_KICK if t == 0 else (CMD_TURN if t % 5 == 0 else CMD_DASH), 70.0, 10.0)
        physics_step(w, c, kp)
    return w


def test_same_seed_gives_identical_arrays_and_another_seed_differs():
    first, second, other = noisy_run(42), noisy_run(42), noisy_run(43)
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(first.pos, other.pos)
    assert not np.array_equal(first.body, other.body)


def test_batch_of_two_equals_two_batches_of_one():
    together = noisy_run(7, batch=2)
    streams = seed_streams(7, 2)
    for b in range(2):
        alone = noisy_run(0, batch=1, streams=streams[b : b + 1])
        for got, expected in zip(alone, together):
            if isinstance(got, np.ndarray):
                np.testing.assert_array_equal(got[0], expected[b])
