"""Kicks: accelerating, freezing and placing the ball, HoldBall and PassBall.

The keepaway-framework's kicking skills (docs/players.md §5.3, §5.4; keepaway-0.6 player/BasicPlayer.cc):
``accelerate_ball_to`` gives the ball a velocity, ``freeze_ball`` stops it, ``kick_close_to_body`` places
it beside me, ``hold_ball`` keeps it from the nearest opponent, and ``kick_to`` / ``pass_ball`` pass it.
Skills as in `agents/movement.py`: kernels on a belief row that return a command triple.
"""

from __future__ import annotations

import math

import numpy as np

from keepaway.agents.belief import Belief
from keepaway.agents.geometry import (
    ball_after_kick,
    ball_in,
    closest_to_ball,
    direction,
    distance,
    distances_from,
    kick_rate,
    kickable_distance,
    normalize_angle,
    opponents,
    own_frame_sign,
    player_step,
    sort_by_distance,
)
from keepaway.agents.movement import turn_to_point
from keepaway.core.jit import borrowing, njit
from keepaway.core.objects import CMD_KICK


@borrowing
def _my_kick_rate(bel: Belief, r: int, kp) -> float:
    me = bel.me[r]
    return kick_rate(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.body[r, me], bel.pos[r, 0, 0], bel.pos[r, 0, 1], kp
    )


@borrowing
def _power_for_speed(speed: float, rate: float) -> float:
    """Kick power giving a velocity change ``speed`` at effective ``rate`` (docs/players.md §5.1)."""
    return speed / rate if rate > 0.0 else math.inf


@borrowing
def accelerate_ball_to(bel: Belief, r: int, wx: float, wy: float, kp) -> tuple:
    """Kick that gives the ball velocity (wx, wy); if one kick cannot, a full-power kick that aligns the
    ball's new velocity with it (BasicPlayer::accelerateBallToVelocity, docs/players.md §5.4)."""
    me = bel.me[r]
    body = bel.body[r, me]
    bvx, bvy = bel.vel[r, 0, 0], bel.vel[r, 0, 1]
    rate = _my_kick_rate(bel, r, kp)
    ax, ay = wx - bvx, wy - bvy
    acc = math.hypot(ax, ay)
    if acc < kp.ball_accel_max:
        power = _power_for_speed(acc, rate)
        if power <= kp.max_power:
            return CMD_KICK, power, normalize_angle(direction(ax, ay) - body)
    speed = rate * kp.max_power
    want = direction(wx, wy)
    rad = math.radians(-want)
    side = bvx * math.sin(rad) + bvy * math.cos(rad)
    ratio = min(1.0, max(-1.0, side / speed)) if speed > 0.0 else 0.0
    kick_dir = want - math.degrees(math.asin(ratio))
    return CMD_KICK, kp.max_power, normalize_angle(kick_dir - body)


@borrowing
def freeze_ball(bel: Belief, r: int, kp, cfg) -> tuple:
    """Stop the ball: kick against its velocity; if that would leave it beyond 0.8 x kickable distance of
    my next position, kick it towards a point inside 0.7 x kickable distance instead (docs/players.md §5.3 step 3)."""
    me = bel.me[r]
    body = bel.body[r, me]
    bx, by = bel.pos[r, 0, 0], bel.pos[r, 0, 1]
    bvx, bvy = bel.vel[r, 0, 0], bel.vel[r, 0, 1]
    rate = _my_kick_rate(bel, r, kp)
    power = min(_power_for_speed(math.hypot(bvx, bvy), rate), kp.max_power)
    kick_dir = normalize_angle(direction(bvx, bvy) + 180.0 - body)
    nx, ny = bel.pos[r, me, 0] + bel.vel[r, me, 0], bel.pos[r, me, 1] + bel.vel[r, me, 1]
    fx, fy, _, _ = ball_after_kick(bx, by, bvx, bvy, rate, power, kick_dir, body, kp)
    kickable = kickable_distance(kp)
    if distance(fx, fy, nx, ny) < cfg.freeze_keep_ratio * kickable:
        return CMD_KICK, power, kick_dir
    reach = min(cfg.freeze_target_ratio * kickable, distance(bx, by, nx, ny) - cfg.freeze_inset)
    aim = math.radians(direction(bx - nx, by - ny))
    return accelerate_ball_to(bel, r, nx + reach * math.cos(aim) - bx, ny + reach * math.sin(aim) - by, kp)


@borrowing
def kick_close_to_body(bel: Belief, r: int, angle: float, ratio: float, kp, cfg) -> tuple:
    """Kick the ball to my next position + (player_size + ball_size + kickable_margin * ratio) at
    ``angle`` relative to my body, pulled back inside the pitch; freeze if one kick cannot compensate a
    moving ball, kick at full power if the ball is still (docs/players.md §5.3 step 3)."""
    me = bel.me[r]
    body = bel.body[r, me]
    nx, ny = bel.pos[r, me, 0] + bel.vel[r, me, 0], bel.pos[r, me, 1] + bel.vel[r, me, 1]
    reach = kp.player_size + kp.ball_size + kp.kickable_margin * ratio
    aim = math.radians(normalize_angle(body + angle))
    cs, sn = math.cos(aim), math.sin(aim)
    half_l, half_w = kp.pitch_length / 2.0, kp.pitch_width / 2.0
    if abs(ny + reach * sn) > half_w and sn != 0.0:
        reach = (math.copysign(half_w, sn) - ny) / sn - cfg.pitch_pullback
    elif abs(nx + reach * cs) > half_l and cs != 0.0:
        reach = (math.copysign(half_l, cs) - nx) / cs - cfg.pitch_pullback
    bvx, bvy = bel.vel[r, 0, 0], bel.vel[r, 0, 1]
    kx = nx + reach * cs - bel.pos[r, 0, 0] - bvx
    ky = ny + reach * sn - bel.pos[r, 0, 1] - bvy
    power = _power_for_speed(math.hypot(kx, ky), _my_kick_rate(bel, r, kp))
    if power > kp.max_power:
        if math.hypot(bvx, bvy) > cfg.still_ball_speed:
            return freeze_ball(bel, r, kp, cfg)
        power = kp.max_power
    return CMD_KICK, power, normalize_angle(direction(kx, ky) - body)


@borrowing
def hold_ball(bel: Belief, r: int, ratio: float, kp, cfg) -> tuple:
    """HoldBall (docs/players.md §5.3): keep the ball ``ratio`` x kickable_margin from the body, away from the
    opponent closest to the ball (rotated 45 deg against its heading) when it is within 5 m; if the ball
    already sits there, turn towards the opponent goal as long as the ball stays controllable."""
    me = bel.me[r]
    px, py, body = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.body[r, me]
    first, last = opponents(bel, me)
    opp = closest_to_ball(bel, r, first, last, -1, cfg)
    desired = 0.0
    if opp >= 0:
        ox, oy = bel.pos[r, opp, 0], bel.pos[r, opp, 1]
        if distance(ox, oy, bel.pos[r, 0, 0], bel.pos[r, 0, 1]) < cfg.hold_opponent_radius:
            phi = direction(px - ox, py - oy)
            side = -1.0 if normalize_angle(bel.body[r, opp] - phi) > 0.0 else 1.0
            desired = normalize_angle(phi + cfg.hold_escape_angle * side - body)
    # The framework tests the relative angle as if it were global (a quirk kept, docs/players.md §5.3 step 2).
    spot_x = px + ratio * math.cos(math.radians(desired))
    spot_y = py + ratio * math.sin(math.radians(desired))
    if distance(spot_x, spot_y, bel.pos[r, 0, 0], bel.pos[r, 0, 1]) < cfg.hold_ball_tolerance:
        goal_x = own_frame_sign(bel, r) * kp.pitch_length / 2.0
        code, a1, a2 = turn_to_point(bel, r, goal_x, 0.0, 1.0, kp)
        mx, my, _, _, _ = player_step(
            px, py, bel.vel[r, me, 0], bel.vel[r, me, 1], body, bel.effort[r], code, a1, kp
        )
        bx, by = ball_in(bel, r, 1.0, kp)
        if distance(mx, my, bx, by) < cfg.hold_turn_safety * kickable_distance(kp):
            return code, a1, a2
    return kick_close_to_body(bel, r, desired, ratio, kp, cfg)


@borrowing
def pass_initial_speed(dist: float, end_speed: float, decay: float) -> tuple:
    """(n, v0): cycles and initial speed for a ball to arrive after ``dist`` with ``end_speed``:
    n = round(log(dist (1/d - 1)/end + 1) / log(1/d)), v0 = end (1/d)^n (docs/players.md §5.4)."""
    inv = 1.0 / decay
    n = math.floor(math.log(dist * (inv - 1.0) / end_speed + 1.0) / math.log(inv) + 0.5)
    return n, end_speed * inv**n


@borrowing
def _full_kick_speed(bvx: float, bvy: float, ux: float, uy: float, kick_speed: float) -> float:
    """The ball speed the C++ kickTo predicts for a full-power kick along (ux, uy): the kick (speed
    ``kick_speed``) aimed so that it cancels the ball's velocity across the line, no caps applied; 0 when
    it cannot (the C++'s asin is then undefined and its test fails)."""
    across = -bvx * uy + bvy * ux
    if abs(across) > kick_speed:
        return 0.0
    return abs(bvx * ux + bvy * uy + math.sqrt(kick_speed**2 - across**2))


@borrowing
def kick_to(bel: Belief, r: int, tx: float, ty: float, end_speed: float, kp, cfg) -> tuple:
    """kickTo(target, end speed) (docs/players.md §5.4): the initial speed that makes the ball arrive at ``end_speed``;
    if the ball's first step would end on my next position, it is shortened/extended to end 0.385 m
    before/after my projection on its line (BasicPlayer::kickTo); too fast -> full-power kick, freeze or
    reposition; too much power -> reposition in front (kick next cycle)."""
    me = bel.me[r]
    bx, by = bel.pos[r, 0, 0], bel.pos[r, 0, 1]
    dist = distance(bx, by, tx, ty)
    if dist == 0.0:
        return kick_close_to_body(bel, r, 0.0, cfg.reposition_ratio, kp, cfg)
    _, v0 = pass_initial_speed(dist, end_speed, kp.ball_decay)
    ux, uy = (tx - bx) / dist, (ty - by) / dist
    nx, ny = bel.pos[r, me, 0] + bel.vel[r, me, 0], bel.pos[r, me, 1] + bel.vel[r, me, 1]
    body_clear = kp.player_size + kp.ball_size
    if distance(bx + v0 * ux, by + v0 * uy, nx, ny) < body_clear:
        along = abs((bel.pos[r, me, 0] - bx) * ux + (bel.pos[r, me, 1] - by) * uy)
        v0 = along - body_clear if v0 < along else along + body_clear
    if v0 > kp.ball_speed_max:
        rate = _my_kick_rate(bel, r, kp)
        if _full_kick_speed(bel.vel[r, 0, 0], bel.vel[r, 0, 1], ux, uy, rate * kp.max_power) > (
            cfg.pass_speed_ratio * kp.ball_accel_max
        ):
            return accelerate_ball_to(bel, r, v0 * ux, v0 * uy, kp)
        if rate > cfg.pass_kick_rate_ratio * kp.kick_power_rate:
            return freeze_ball(bel, r, kp, cfg)
        return kick_close_to_body(bel, r, 0.0, cfg.reposition_ratio, kp, cfg)
    power = _power_for_speed(
        math.hypot(v0 * ux - bel.vel[r, 0, 0], v0 * uy - bel.vel[r, 0, 1]), _my_kick_rate(bel, r, kp)
    )
    pressed = False
    if power <= cfg.pass_power_pressed:
        first, last = opponents(bel, me)
        opp = closest_to_ball(bel, r, first, last, -1, cfg)
        if opp >= 0:
            pressed = distance(bel.pos[r, opp, 0], bel.pos[r, opp, 1], bx, by) < cfg.pass_pressure_radius
    if power <= cfg.pass_power_ok or pressed:
        return accelerate_ball_to(bel, r, v0 * ux, v0 * uy, kp)
    return kick_close_to_body(bel, r, 0.0, cfg.reposition_ratio, kp, cfg)


@njit(cache=True)
def pass_ball(bel: Belief, r: int, k: int, kp, cfg) -> tuple:
    """PassBall-k (docs/players.md §2 step 3d, §5.4): kickTo the k-th nearest keeper from me (k = 1 nearest teammate),
    resolved from the current positions, at the pass end speed."""
    me = bel.me[r]
    order = np.empty(bel.n_keepers, dtype=np.int64)
    dist = np.empty(bel.n_keepers + 1)
    distances_from(bel, r, bel.pos[r, me, 0], bel.pos[r, me, 1], bel.n_keepers, me, dist)
    sort_by_distance(dist, 1, bel.n_keepers, me, order)
    target = order[k - 1]
    return kick_to(bel, r, bel.pos[r, target, 0], bel.pos[r, target, 1], cfg.pass_end_speed, kp, cfg)


__all__ = ["accelerate_ball_to", "freeze_ball", "hold_ball", "kick_close_to_body", "kick_to", "pass_ball",
           "pass_initial_speed"]
