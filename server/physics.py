"""rcssserver's physics as numba kernels over a batch of arenas (spec `server-physics.md` 2, 3, 7, 8).

Each kernel works on one arena ``b`` of a :class:`server.world.World` and reads every constant from the
kernel parameter record ``kp`` (``ServerParams.kernel()``), so the simulation composes them in one njit
loop over the batch, in rcssserver's order (spec 2, "Step"):

1. :func:`apply_commands`: this cycle's resolved dash/turn/kick and turn_neck (``Player::dash``, ``turn``,
   ``kick``, ``turn_neck``); dash and kick accelerations are added to ``w.acc``, turns become pending;
2. :func:`move_objects`: ``MPObject::_inc`` for every enabled object;
3. :func:`resolve_collisions`: ``Stadium::collisions``;
4. ``time += 1`` (then the referees run, in the simulation);
5. :func:`update_stamina`: ``Player::updateStamina`` for every enabled player.

:func:`physics_step` is the plain batch entry for all of it; :func:`place_object` is the trainer's move.
Angles are kept in degrees (rcssserver works in radians; the difference is rounding only). Every random
draw comes from the arena's own stream ``w.rng[b]``, so a batch draws exactly what its arenas would draw
one at a time. Goal-post bounces (spec 2 step 1d) are left out: Keepaway is played in a 20 x 20 m square
at the centre of the pitch, far from the posts, and wind is zero.
"""

from __future__ import annotations

import math

import numpy as np
from keepaway.core.jit import borrowing, njit

from keepaway.protocol.params import NOISE_POLAR
from keepaway.core.rng import randint, uniform
from keepaway.core.objects import BALL, CMD_DASH, CMD_KICK, CMD_TURN, COLLISION_VEL_FACTOR
from keepaway.server.world import (
    COLLIDED_BALL,
    COLLIDED_PLAYER,
    COUNT_DASH,
    COUNT_KICK,
    COUNT_TURN,
    COUNT_TURN_NECK,
    Commands,
    World,
)

# Constants of rcssserver's code, not server parameters (utility.h, stadium.cpp, object.h).
EPS = 1.0e-10  # separation margin of a collision and the floor of PVector::normalize
COLLISION_PASSES = 10  # Stadium::collisions: at most 10 passes
COLLISION_ENLARGE = 1.0001  # calcCollisionPos: +0.01 % per retry while rounding leaves an overlap
COLLISION_ENLARGE_TRIES = 10

# Columns of the collision scratch array: accumulated target position, number of targets, collided.
_SUM_X, _SUM_Y, _COUNT, _COLLIDED = range(4)


@njit(cache=True, inline="always")
def normalize_angle(deg: float) -> float:
    """Angle in (-180, 180] degrees."""
    if abs(deg) > 360.0:
        deg = np.fmod(deg, 360.0)
    if deg > 180.0:
        deg -= 360.0
    elif deg <= -180.0:
        deg += 360.0
    return deg


@njit(cache=True, inline="always")
def _clamp(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


@njit(cache=True, inline="always")
def _direction_deg(dx: float, dy: float) -> float:
    """PVector::th in degrees: atan2, with 0 for the zero vector."""
    if dx == 0.0 and dy == 0.0:
        return 0.0
    return math.degrees(math.atan2(dy, dx))


@njit(cache=True, inline="always")
def dash_direction_rate(direction: float, kp) -> float:
    """Power factor of a dash ``direction`` degrees off the body (spec 3, CURRENT; 1.0 straight ahead)."""
    d = abs(direction)
    if d > 90.0:
        rate = kp.back_dash_rate - (kp.back_dash_rate - kp.side_dash_rate) * (1.0 - (d - 90.0) / 90.0)
    else:
        rate = kp.side_dash_rate + (1.0 - kp.side_dash_rate) * (1.0 - d / 90.0)
    return _clamp(rate, 0.0, 1.0)


@borrowing
def dash(b: int, w: World, i: int, power: float, direction: float, kp) -> None:
    """``Player::dash``: stamina cost, then an acceleration along body + direction into ``w.acc`` (spec 3).

    CLASSIC is the same code with ``min_dash_angle == max_dash_angle == 0`` (no direction, rate 1) and
    ``min_dash_power = -100``: a negative power costs 2|power| and pushes backwards."""
    power = _clamp(power, kp.min_dash_power, kp.max_dash_power)
    direction = _clamp(direction, kp.min_dash_angle, kp.max_dash_angle)
    if kp.dash_angle_step >= EPS:
        direction = kp.dash_angle_step * np.rint(direction / kp.dash_angle_step)
    back = power < 0.0
    need = -2.0 * power if back else power
    need = min(need, w.stamina[b, i] + kp.extra_stamina)
    w.stamina[b, i] = max(0.0, w.stamina[b, i] - need)
    power = -need / 2.0 if back else need
    accel = abs(w.effort[b, i] * power * dash_direction_rate(direction, kp) * kp.dash_power_rate)
    if back:
        direction += 180.0
    angle = math.radians(w.body[b, i] + direction)
    w.acc[b, i, 0] += accel * math.cos(angle)
    w.acc[b, i, 1] += accel * math.sin(angle)
    w.counts[b, i, COUNT_DASH] += 1


@borrowing
def turn(b: int, w: World, i: int, moment: float, kp) -> None:
    """``Player::turn``: the pending body angle, slowed by inertia at the stored speed (spec 3)."""
    moment = _clamp(moment, kp.min_moment, kp.max_moment)
    noise = 1.0 + uniform(w.rng, b, -kp.player_rand, kp.player_rand)
    speed = math.hypot(w.vel[b, i, 0], w.vel[b, i, 1])
    w.body_pending[b, i] = normalize_angle(w.body[b, i] + noise * moment / (1.0 + kp.inertia_moment * speed))
    w.counts[b, i, COUNT_TURN] += 1


@borrowing
def turn_neck(b: int, w: World, i: int, moment: float, kp) -> None:
    """``Player::turn_neck``: pending neck angle relative to the body, clamped; no noise (spec 3)."""
    moment = _clamp(moment, kp.min_neck_moment, kp.max_neck_moment)
    w.neck_pending[b, i] = _clamp(w.neck[b, i] + moment, kp.min_neck_angle, kp.max_neck_angle)
    w.counts[b, i, COUNT_TURN_NECK] += 1


@borrowing
def kick_possible(b: int, w: World, i: int, kp) -> bool:
    """``Player::ballKickable``: enabled player whose centre is within 0.3 + 0.7 + 0.085 m of the ball's."""
    if i == BALL or not w.enabled[b, i]:
        return False
    dx = w.pos[b, BALL, 0] - w.pos[b, i, 0]
    dy = w.pos[b, BALL, 1] - w.pos[b, i, 1]
    reach = kp.player_size + kp.kickable_margin + kp.ball_size
    return dx * dx + dy * dy <= reach * reach


@borrowing
def kick(b: int, w: World, i: int, power: float, direction: float, kp) -> None:
    """``Player::kick`` in play_on: effective power by distance and angle, plus noise, added to the
    ball's acceleration (spec 3). Marks the kicker even when the ball is out of reach (``KICK`` state);
    only a kick that reaches the ball is counted."""
    w.kicked[b, i] = True
    if not kick_possible(b, w, i, kp):
        return
    power = _clamp(power, kp.min_power, kp.max_power)
    direction = _clamp(direction, kp.min_moment, kp.max_moment)
    dx = w.pos[b, BALL, 0] - w.pos[b, i, 0]
    dy = w.pos[b, BALL, 1] - w.pos[b, i, 1]
    dir_diff = abs(normalize_angle(_direction_deg(dx, dy) - w.body[b, i])) / 180.0
    dist_ball = (math.hypot(dx, dy) - kp.player_size - kp.ball_size) / kp.kickable_margin
    eff = power * kp.kick_power_rate * (1.0 - 0.25 * dir_diff - 0.25 * dist_ball)
    angle = math.radians(direction + w.body[b, i])
    ax = eff * math.cos(angle)
    ay = eff * math.sin(angle)
    if kp.kick_noise == NOISE_POLAR:
        pos_rate = 0.5 + 0.25 * (dir_diff + dist_ball)
        ball_speed = math.hypot(w.vel[b, BALL, 0], w.vel[b, BALL, 1])
        speed_rate = 0.5 + 0.5 * ball_speed / (kp.ball_speed_max * kp.ball_decay)
        max_rand = kp.kick_rand * (power / kp.max_power) * (pos_rate + speed_rate)
        length = uniform(w.rng, b, 0.0, max_rand)
        theta = uniform(w.rng, b, -math.pi, math.pi)
        ax += length * math.cos(theta)
        ay += length * math.sin(theta)
    else:
        r = kp.kick_rand * power / kp.max_power
        ax += uniform(w.rng, b, -r, r)
        ay += uniform(w.rng, b, -r, r)
    w.acc[b, BALL, 0] += ax
    w.acc[b, BALL, 1] += ay
    w.counts[b, i, COUNT_KICK] += 1


@borrowing
def apply_commands(b: int, w: World, c: Commands, kp) -> None:
    """Execute the already-resolved main command and the turn_neck of every enabled player (spec 3).

    tackle, move and catch have no effect in play_on and rcssserver counts none of them there (a move
    outside before_kick_off/after_goal and a non-goalie catch return before their counter); the tackle
    counter is not one of the eight sense_body counts."""
    for i in range(w.pos.shape[1]):
        w.kicked[b, i] = False
    for i in range(1, w.pos.shape[1]):
        if not w.enabled[b, i]:
            continue
        command = c.main[b, i]
        if command == CMD_DASH:
            dash(b, w, i, c.arg1[b, i], c.arg2[b, i], kp)
        elif command == CMD_TURN:
            turn(b, w, i, c.arg1[b, i], kp)
        elif command == CMD_KICK:
            kick(b, w, i, c.arg1[b, i], c.arg2[b, i], kp)
        if c.has_neck[b, i]:
            turn_neck(b, w, i, c.neck[b, i], kp)


@borrowing
def _move_object(b: int, w: World, i: int, decay: float, rand: float, speed_max: float,
                 accel_max: float, kp) -> None:
    """``MPObject::_inc`` for one object (spec 2 step 1 a-e)."""
    ax = w.acc[b, i, 0]
    ay = w.acc[b, i, 1]
    vx = w.vel[b, i, 0]
    vy = w.vel[b, i, 1]
    if ax != 0.0 or ay != 0.0:
        a = math.hypot(ax, ay)
        if a > accel_max:
            ax *= accel_max / a
            ay *= accel_max / a
        vx += ax
        vy += ay
        s = math.hypot(vx, vy)
        if s > speed_max:
            vx *= speed_max / s
            vy *= speed_max / s
    if i != BALL:
        w.body[b, i] = w.body_pending[b, i]
        w.neck[b, i] = w.neck_pending[b, i]
    r = rand * math.hypot(vx, vy)
    if kp.movement_noise == NOISE_POLAR:
        length = uniform(w.rng, b, 0.0, r)
        theta = uniform(w.rng, b, -math.pi, math.pi)
        vx += length * math.cos(theta)
        vy += length * math.sin(theta)
    else:
        vx += uniform(w.rng, b, -r, r)
        vy += uniform(w.rng, b, -r, r)
    w.pos[b, i, 0] += vx
    w.pos[b, i, 1] += vy
    w.vel[b, i, 0] = vx * decay
    w.vel[b, i, 1] = vy * decay
    w.acc[b, i, 0] = 0.0
    w.acc[b, i, 1] = 0.0


@borrowing
def move_objects(b: int, w: World, kp) -> None:
    """Step 1 of spec 2 for every enabled object; also starts this step's collision flags afresh.

    rcssserver shuffles the objects before moving them. Each object moves independently, so the order
    only decides which object consumes which draws; a random rotation of the object order (one draw)
    does the same without a scratch array."""
    n = w.pos.shape[1]
    start = randint(w.rng, b, n)
    for k in range(n):
        i = (start + k) % n
        w.collision[b, i] = 0
        if not w.enabled[b, i]:
            continue
        if i == BALL:
            _move_object(b, w, i, kp.ball_decay, kp.ball_rand, kp.ball_speed_max, kp.ball_accel_max, kp)
        else:
            _move_object(b, w, i, kp.player_decay, kp.player_rand, kp.player_speed_max,
                         kp.player_accel_max, kp)


@njit(cache=True, inline="always")
def _size(i: int, kp) -> float:
    return kp.ball_size if i == BALL else kp.player_size


@njit(cache=True, inline="always")
def _overlap(b: int, w: World, i: int, j: int, kp) -> bool:
    """Both enabled and centres closer than the sum of the radii (distance2 < (r1 + r2)^2)."""
    if not (w.enabled[b, i] and w.enabled[b, j]):
        return False
    dx = w.pos[b, i, 0] - w.pos[b, j, 0]
    dy = w.pos[b, i, 1] - w.pos[b, j, 1]
    reach = _size(i, kp) + _size(j, kp)
    return dx * dx + dy * dy < reach * reach


@borrowing
def _any_overlap(b: int, w: World, kp) -> bool:
    n = w.pos.shape[1]
    for i in range(n - 1):
        for j in range(i + 1, n):
            if _overlap(b, w, i, j, kp):
                return True
    return False


@borrowing
def _collide_pair(b: int, w: World, i: int, j: int, scratch: np.ndarray, kp) -> None:
    """``Stadium::calcCollisionPos``: both objects go to the midpoint plus half the separation distance
    (+EPS) along midpoint-to-object, enlarged x1.0001 while rounding still leaves an overlap."""
    ix = w.pos[b, i, 0]
    iy = w.pos[b, i, 1]
    jx = w.pos[b, j, 0]
    jy = w.pos[b, j, 1]
    mx = (ix + jx) / 2.0
    my = (iy + jy) / 2.0
    ax = ix - mx
    ay = iy - my
    bx = jx - mx
    by = jy - my
    half = (_size(i, kp) + _size(j, kp)) / 2.0 + EPS
    if (ix == jx and iy == jy) or (math.hypot(ax, ay) < EPS and math.hypot(bx, by) < EPS):
        theta = uniform(w.rng, b, -math.pi, math.pi)
        ax = half * math.cos(theta)
        ay = half * math.sin(theta)
        bx = -ax
        by = -ay
    else:
        scale_a = half / max(math.hypot(ax, ay), EPS)
        scale_b = half / max(math.hypot(bx, by), EPS)
        ax *= scale_a
        ay *= scale_a
        bx *= scale_b
        by *= scale_b
    reach = _size(i, kp) + _size(j, kp)
    for _ in range(COLLISION_ENLARGE_TRIES):
        dx = ax - bx
        dy = ay - by
        if dx * dx + dy * dy >= reach * reach:
            break
        ax *= COLLISION_ENLARGE
        ay *= COLLISION_ENLARGE
        bx *= COLLISION_ENLARGE
        by *= COLLISION_ENLARGE
    scratch[i, _SUM_X] += mx + ax
    scratch[i, _SUM_Y] += my + ay
    scratch[i, _COUNT] += 1.0
    scratch[i, _COLLIDED] = 1.0
    scratch[j, _SUM_X] += mx + bx
    scratch[j, _SUM_Y] += my + by
    scratch[j, _COUNT] += 1.0
    scratch[j, _COLLIDED] = 1.0


@njit(cache=True)
def resolve_collisions(b: int, w: World, kp) -> None:
    """``Stadium::collisions`` in play_on (spec 2 "Collisions", spec 8): end positions only, no sweep.

    Up to 10 passes; in each, the ball is checked against every player, then every pair of players, all
    from the positions at the start of the pass; each object then moves to the average of its targets.
    Afterwards every object that collided has v *= -0.1 (once). Sets ``w.collision`` bits: a player
    touched by the ball gets COLLIDED_BALL, players touching players (and the ball touched by a player)
    get COLLIDED_PLAYER. The scratch array is only allocated in the rare cycles that have a collision."""
    if not _any_overlap(b, w, kp):
        return
    n = w.pos.shape[1]
    scratch = np.zeros((n, 4))
    for _ in range(COLLISION_PASSES):
        collided = False
        for i in range(1, n):
            if _overlap(b, w, BALL, i, kp):
                collided = True
                w.collision[b, i] |= COLLIDED_BALL
                w.collision[b, BALL] |= COLLIDED_PLAYER
                _collide_pair(b, w, BALL, i, scratch, kp)
        for i in range(1, n - 1):
            for j in range(i + 1, n):
                if _overlap(b, w, i, j, kp):
                    collided = True
                    w.collision[b, i] |= COLLIDED_PLAYER
                    w.collision[b, j] |= COLLIDED_PLAYER
                    _collide_pair(b, w, i, j, scratch, kp)
        for i in range(n):
            count = scratch[i, _COUNT]
            if count > 0.0:
                w.pos[b, i, 0] = scratch[i, _SUM_X] / count
                w.pos[b, i, 1] = scratch[i, _SUM_Y] / count
            scratch[i, _SUM_X] = 0.0
            scratch[i, _SUM_Y] = 0.0
            scratch[i, _COUNT] = 0.0
        if not collided:
            break
    for i in range(n):
        if scratch[i, _COLLIDED] > 0.0:
            w.vel[b, i, 0] *= COLLISION_VEL_FACTOR
            w.vel[b, i, 1] *= COLLISION_VEL_FACTOR


@borrowing
def update_stamina(b: int, w: World, kp) -> None:
    """``Player::updateStamina`` for every enabled player (spec 3 "Stamina").

    The effort increase threshold is effort_dec_thr under CLASSIC (its bug, ``effort_inc_uses_dec_thr``)
    and effort_inc_thr from 12.0; the capacity model (13.0+) is on when ``stamina_capacity >= 0``."""
    inc_thr = kp.effort_dec_thr if kp.effort_inc_uses_dec_thr != 0.0 else kp.effort_inc_thr
    for i in range(1, w.pos.shape[1]):
        if not w.enabled[b, i]:
            continue
        stamina = w.stamina[b, i]
        if stamina <= kp.recover_dec_thr * kp.stamina_max:
            if w.recovery[b, i] > kp.recover_min:
                w.recovery[b, i] -= kp.recover_dec
            if w.recovery[b, i] < kp.recover_min:
                w.recovery[b, i] = kp.recover_min
        if stamina <= kp.effort_dec_thr * kp.stamina_max:
            if w.effort[b, i] > kp.effort_min:
                w.effort[b, i] -= kp.effort_dec
            if w.effort[b, i] < kp.effort_min:
                w.effort[b, i] = kp.effort_min
        if stamina >= inc_thr * kp.stamina_max and w.effort[b, i] < kp.effort_max:
            w.effort[b, i] = min(w.effort[b, i] + kp.effort_inc, kp.effort_max)
        gain = min(w.recovery[b, i] * kp.stamina_inc_max, kp.stamina_max - stamina)
        if kp.stamina_capacity >= 0.0:
            gain = min(gain, w.capacity[b, i])
            w.capacity[b, i] = max(0.0, w.capacity[b, i] - gain)
        w.stamina[b, i] = min(stamina + gain, kp.stamina_max)


@borrowing
def place_object(b: int, w: World, i: int, x: float, y: float, vx: float, vy: float,
                 body_or_nan: float, kp) -> None:
    """The trainer's move (``Stadium::moveBall`` / ``movePlayer``): position, velocity, no acceleration,
    and for a player the body angle (effective and pending) unless NaN. A player move runs the collision
    routine at once, as rcssserver does (spec 2; traces README "Setup at cycle 0")."""
    w.pos[b, i, 0] = x
    w.pos[b, i, 1] = y
    w.vel[b, i, 0] = vx
    w.vel[b, i, 1] = vy
    w.acc[b, i, 0] = 0.0
    w.acc[b, i, 1] = 0.0
    if i == BALL:
        return
    if not math.isnan(body_or_nan):
        w.body[b, i] = body_or_nan
        w.body_pending[b, i] = body_or_nan
    resolve_collisions(b, w, kp)


@borrowing
def physics_step(w: World, c: Commands, kp) -> None:
    """One play_on cycle of every arena without a referee: commands, movement, collisions, time, stamina
    (spec 2, steps 0-3 and 5)."""
    for b in range(w.pos.shape[0]):
        apply_commands(b, w, c, kp)
        move_objects(b, w, kp)
        resolve_collisions(b, w, kp)
        w.time[b] += 1
        update_stamina(b, w, kp)


__all__ = [
    "apply_commands",
    "dash",
    "dash_direction_rate",
    "kick",
    "kick_possible",
    "move_objects",
    "normalize_angle",
    "physics_step",
    "place_object",
    "resolve_collisions",
    "turn",
    "turn_neck",
    "update_stamina",
]
