"""The players' world model: localisation and tracking from noisy percepts.

A player only sees quantised, partial percepts (docs/rules.md §5). This module keeps, per
deciding player (one row of a batch), an estimate of every object and writes it as one row of a
:class:`agents.belief.Belief`:

* **prediction** (every cycle): my own motion from the commands I sent, with the server's model (dash
  acceleration with effort along the body, turn with inertia, neck, decay; docs/rules.md §1, §2) and no noise, but
  with the C++ players' belief that a negative dash power moves me backwards
  (``geometry.believed_dash_power``); my kick changes the ball's velocity; the ball and the other players
  roll out their velocities with decay;
* **sense_body**: my neck (head_angle), velocity (speed) and effort, both angles truncated to integers;
  a collision guessed from the speed, as the C++ guesses it; and my position as the C++ sets it: moved by
  the sensed speed from where I was a cycle ago, unless I guessed a collision (then as predicted);
* **see**: self-localisation from the flags, a weighted 2-D rigid fit (Procrustes) of the flags' relative
  positions onto their global positions, which gives my head direction and position without a prior; the
  players, then the ball, from their polar observations, velocities from dist_chg/dir_chg (docs/rules.md
  §5.2), unnamed players associated with the nearest compatible predicted player;
* **confidence** conf = 1 - (cycles since seen)/100, 1 for myself (docs/players.md §4.1).

The ball follows the rules of the keepaway-0.6 C++ players' world model (tjpalmer/keepaway
`player/WorldModelUpdate.cc`; docs/design.md, "The ball in the players' world model"), which keepers and
takers share: a ball that an opponent can kick is believed to stand still (in the prediction and after a
see), a seen velocity is averaged with the predicted one when they agree, a velocity from position
differences is refused where a player could have kicked the ball or I collided, and a guessed collision
puts a ball nearer to me than to anyone else out of me. The players' own settings
(``AgentConfig``: which players are usable) enter these rules as in the C++
(``PlayerSettings::getPlayerConfThr``).

What a teammate says is taken in by `agents/say.py` (on these arrays, after the see). Not modelled:
the line observations (the flags suffice), fusing successive noisy sightings of a player (each see
replaces the estimate), commands that arrive late and act a cycle later, and the C++ model's guesses
about unseen players (moving the fastest opponent towards the ball).

Hot paths are ``@njit`` kernels over arrays with a row per player; a row kernel takes the row index ``r``
so the batched mode can compose them in one loop. :class:`WorldModel` is the per-process Python wrapper
(B = 1) that unpacks decoded wire payloads (`protocol` messages ``see``, ``sense_body``, ``fullstate``)
into preallocated arrays.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from keepaway.agents.belief import Belief, empty_belief
from keepaway.agents.frames import (
    EFFORT,
    FRAME_VALUES,
    HEAD_ANGLE,
    NOT_TAKEN,
    SEE,
    SENSE_BODY,
    SIDE_CODES,
    SPEED_AMOUNT,
    SPEED_DIRECTION,
    STAMINA,
    decode_frame,
)
from keepaway.agents.frames import NO_SIDE as _NO_SIDE
from keepaway.agents.frames import NO_UNUM as _NO_UNUM
from keepaway.agents.geometry import believed_dash_power, compared_hypot, kick_rate, nearer_than, normalize_angle, turn_effect
from keepaway.agents.skills import AgentConfig, kickable_distance, opponent_range
from keepaway.core.jit import SteadyCall, borrowing, njit
from keepaway.core.objects import BALL, CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN, COLLISION_VEL_FACTOR
from keepaway.protocol.params import ServerParams

# Confidence falls to 0 after this many unseen cycles (docs/players.md §4.1).
CONF_HORIZON_CYCLES = 100.0
# Percept directions are whole degrees (docs/rules.md §5.2).
DIR_STEP_DEG = 1.0
# The outer quantisation of every seen distance, Q(exp(Q(ln d, q)), 0.1) (docs/rules.md §5.2).
DIST_PRINT_STEP = 0.1
# WorldModel::calculateStateBall (WorldModelUpdate.cc): a velocity from two ball positions seen 2 cycles
# apart is refused if I collided within this many cycles (1 cycle apart: if the last sense showed one).
POSITION_DIFF_COLLISION_CYCLES = 3
# WorldModel::updateAgentAndBallAfterSense: a collision is guessed when my sensed speed is below
# SPEED_EPSILON (Geometry.h EPSILON) while I was predicted to move faster than COLLISION_MOVING_SPEED with
# the ball within COLLISION_BALL_NEAR (m) ...
SPEED_EPSILON = 0.0001
COLLISION_MOVING_SPEED = 0.01
COLLISION_BALL_NEAR = 0.8
COLLISION_BALL_MARGIN = 0.5  # or within kickable + this (m) ...
COLLISION_SMALL_COMPONENT = 0.08  # ... each velocity component flipped or below this ...
COLLISION_SPEED_DROP = 0.25  # ... and the speed below this fraction of the predicted one
# WorldModel::updateBallForCollision: the ball is put this far from my centre (m), towards where it was.
COLLISION_BALL_DISTANCE = 0.2
# The largest frame on_frame's kernel reads (bytes): the server's sees, its largest per-cycle
# frames, are at most 3,444 bytes in 3v2, 4,991 in 11v11 (server.percept_wire.see_frame_bytes). A larger
# one is decoded in full.
FRAME_BYTES = 8192
# seen/obs time of an object never seen since the last forget.
NEVER = -(1 << 40)
# Association tiers (the nearest compatible predicted player first): a player within its reach beats a never
# seen one, which beats one that could not have moved there.
_UNSEEN_COST = 1.0e6


def whole_degree_table() -> np.ndarray:
    """(cos, sin) of radians(d) for every whole degree d in -180..180 (row d + 180), computed by the
    functions the kernels call (Python's math and numba's both call the C library's, on the same
    double): a flag's seen direction is a whole degree, so ``localise_row`` looks them up."""
    return np.array([[math.cos(math.radians(d)), math.sin(math.radians(d))] for d in range(-180, 181)])


_WHOLE_DEGREES = whole_degree_table()


class ModelState(NamedTuple):
    """The world model of ``B`` players (a row each), updated in place by the kernels."""

    time: np.ndarray  # (B,) int64 cycle of the estimate; -1 before the first percept
    me: np.ndarray  # (B,) int64 my object index
    pos: np.ndarray  # (B, N, 2) estimated positions
    vel: np.ndarray  # (B, N, 2) estimated stored (post-decay) velocities
    body: np.ndarray  # (B, N) global body angles, deg
    neck: np.ndarray  # (B, N) necks relative to the bodies, deg
    seen: np.ndarray  # (B, N) int64 cycle each object was last seen (NEVER if not since forget)
    err: np.ndarray  # (B, N) how far a player may have moved since it was seen, m (association gate)
    obs_pos: np.ndarray  # (B, N, 2) position of the last observation (for position differences)
    obs_time: np.ndarray  # (B, N) int64 its cycle (``seen`` may be set by hearing, `agents/say.py`)
    ball_chg: np.ndarray  # (B,) int64 cycle of the last see with the ball's change pair (C++ getTimeChangeInformation)
    stamina: np.ndarray  # (B,) my stamina (sense_body)
    effort: np.ndarray  # (B,) my effort (sense_body)
    speed: np.ndarray  # (B, 2) sense_body speed [amount, direction relative to head (truncated deg)]
    speed_time: np.ndarray  # (B,) int64 cycle of that speed
    cmd_main: np.ndarray  # (B,) int8 my main command of this cycle (CMD_*), applied at the next step
    cmd_args: np.ndarray  # (B, 3) its arg1, arg2 and my turn_neck moment
    kicked: np.ndarray  # (B,) bool my last predicted step had a kick command (C++ m_bPerformedKick)
    collided: np.ndarray  # (B,) bool my last sense_body suggested a collision (C++ m_bWasCollision)
    collision_time: np.ndarray  # (B,) int64 cycle of that collision (NEVER if none)
    loc_shift: np.ndarray  # (B, 2) my seen minus predicted position at the last see (C++ PositionDifference)


class SeeBuffer(NamedTuple):
    """One ``see`` per row, unpacked (cycle < 0: no see for the row). NaN marks an omitted field."""

    cycle: np.ndarray  # (B,) int64
    n_flags: np.ndarray  # (B,) int64
    flag_id: np.ndarray  # (B, F) int64 index into the landmark table
    flag_obs: np.ndarray  # (B, F, 2) [dist, dir]
    ball_seen: np.ndarray  # (B,) bool
    ball_obs: np.ndarray  # (B, 4) [dist, dir, dist_chg, dir_chg]
    n_players: np.ndarray  # (B,) int64
    player_side: np.ndarray  # (B, P) int64 SIDE_CODES or -1
    player_unum: np.ndarray  # (B, P) int64, 0 if unknown
    player_obs: np.ndarray  # (B, P, 6) [dist, dir, dist_chg, dir_chg, body_dir, head_dir]
    target: np.ndarray  # (B, P) int64 scratch: object each observation was assigned to
    taken: np.ndarray  # (B, N) bool scratch: objects already assigned
    cost: np.ndarray  # (B, P, N) scratch: association costs
    flag_q: np.ndarray  # (B, F, 3) scratch: each flag's weight and relative position [w, d cos, d sin]


def new_model_state(batch: int, n_keepers: int, n_takers: int, me: np.ndarray | int,
                    params: ServerParams) -> ModelState:
    """A model that knows nothing yet (every object unseen), for players ``me`` (object indices)."""
    n = 1 + n_keepers + n_takers
    return ModelState(
        time=np.full(batch, -1, dtype=np.int64),
        me=np.array(np.broadcast_to(np.asarray(me, dtype=np.int64), (batch,))),
        pos=np.zeros((batch, n, 2)),
        vel=np.zeros((batch, n, 2)),
        body=np.zeros((batch, n)),
        neck=np.zeros((batch, n)),
        seen=np.full((batch, n), NEVER, dtype=np.int64),
        err=np.zeros((batch, n)),
        obs_pos=np.zeros((batch, n, 2)),
        obs_time=np.full((batch, n), NEVER, dtype=np.int64),
        ball_chg=np.full(batch, NEVER, dtype=np.int64),
        stamina=np.full(batch, params.stamina_max),
        effort=np.full(batch, params.effort_init),
        speed=np.zeros((batch, 2)),
        speed_time=np.full(batch, NEVER, dtype=np.int64),
        cmd_main=np.full(batch, CMD_NONE, dtype=np.int8),
        cmd_args=np.zeros((batch, 3)),
        kicked=np.zeros(batch, dtype=np.bool_),
        collided=np.zeros(batch, dtype=np.bool_),
        collision_time=np.full(batch, NEVER, dtype=np.int64),
        loc_shift=np.zeros((batch, 2)),
    )


def new_see_buffer(batch: int, n_flags: int, n_objects: int) -> SeeBuffer:
    """Preallocated see arrays for ``batch`` rows (at most every other player is seen)."""
    n_players = n_objects - 2
    return SeeBuffer(
        cycle=np.full(batch, -1, dtype=np.int64),
        n_flags=np.zeros(batch, dtype=np.int64),
        flag_id=np.zeros((batch, n_flags), dtype=np.int64),
        flag_obs=np.zeros((batch, n_flags, 2)),
        ball_seen=np.zeros(batch, dtype=np.bool_),
        ball_obs=np.full((batch, 4), np.nan),
        n_players=np.zeros(batch, dtype=np.int64),
        player_side=np.full((batch, n_players), _NO_SIDE, dtype=np.int64),
        player_unum=np.zeros((batch, n_players), dtype=np.int64),
        player_obs=np.full((batch, n_players, 6), np.nan),
        target=np.zeros((batch, n_players), dtype=np.int64),
        taken=np.zeros((batch, n_objects), dtype=np.bool_),
        cost=np.zeros((batch, n_players, n_objects)),
        flag_q=np.zeros((batch, n_flags, 3)),
    )


# ---------------------------------------------------------------------------------------------------
# small numeric helpers


@njit(cache=True, inline="always")
def _clamp(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True, inline="always")
def _truncated_centre(v):
    """Centre of the values that C truncation maps to the integer ``v`` (docs/rules.md §5.3)."""
    if v > 0.0:
        return v + 0.5 * DIR_STEP_DEG
    if v < 0.0:
        return v - 0.5 * DIR_STEP_DEG
    return 0.0


@njit(cache=True, inline="always")
def _observation_bounds(dist, q):
    """Worst-case error of a point seen at quantised distance ``dist`` with log-step ``q`` (docs/rules.md §5.2):
    radial, e^(q/2) - 1 relative plus the 0.05 m print rounding; lateral, half a degree."""
    radial = dist * (math.exp(0.5 * q) - 1.0) + 0.5 * DIST_PRINT_STEP
    return radial, dist * math.radians(0.5 * DIR_STEP_DEG)


@njit(cache=True, inline="always")
def _flag_weight(dist, kp):
    """Inverse variance of a flag's relative position: uniform quantisation of ln d (step
    quantize_step_l), of the direction (1 deg) and of the printed distance (0.1 m), docs/rules.md §5.2."""
    rel = (kp.quantize_step_l ** 2 + math.radians(DIR_STEP_DEG) ** 2) / 12.0
    return 1.0 / (dist * dist * rel + DIST_PRINT_STEP ** 2 / 12.0)


@borrowing
def confidence(r: int, s: ModelState, obj: int) -> float:
    """conf = 1 - (cycles since seen)/100 in [0, 1], 1 for me (docs/players.md §4.1)."""
    if obj == s.me[r]:
        return 1.0
    return _clamp(1.0 - float(s.time[r] - s.seen[r, obj]) / CONF_HORIZON_CYCLES, 0.0, 1.0)


@borrowing
def _closest_player(r, s, x, y, lo, hi, skip, cfg):
    """The usable player (conf >= player_conf_threshold, me included) among objects ``lo``..``hi - 1``
    other than ``skip`` nearest to (x, y), and its distance; (-1, inf) if none. The C++ world model's
    ``getClosestInSetTo`` with its default confidence threshold."""
    best = -1
    best_d = np.inf
    for obj in range(lo, hi):
        if obj == skip or confidence(r, s, obj) < cfg.player_conf_threshold:
            continue
        d = nearer_than(s.pos[r, obj, 0] - x, s.pos[r, obj, 1] - y, best_d)
        if d < best_d:
            best = obj
            best_d = d
    return best, best_d


# ---------------------------------------------------------------------------------------------------
# prediction (docs/rules.md §1, §2, without noise)


@borrowing
def _ball_kickable_by_me(r, s, kp):
    """Whether the estimated ball is within my kickable distance."""
    me = s.me[r]
    kickable = kickable_distance(kp)
    dx, dy = s.pos[r, BALL, 0] - s.pos[r, me, 0], s.pos[r, BALL, 1] - s.pos[r, me, 1]
    return compared_hypot(dx, dy, kickable) <= kickable


@borrowing
def _kick_acceleration(r, s, power, direction, kp):
    """The acceleration my kick gives a kickable ball (docs/rules.md §2, "kick")."""
    me = s.me[r]
    px, py = s.pos[r, me, 0], s.pos[r, me, 1]
    bx, by = s.pos[r, BALL, 0], s.pos[r, BALL, 1]
    power = _clamp(power, kp.min_power, kp.max_power)
    direction = _clamp(direction, kp.min_moment, kp.max_moment)
    eff = power * kick_rate(px, py, s.body[r, me], bx, by, kp)
    a = math.radians(s.body[r, me] + direction)
    return eff * math.cos(a), eff * math.sin(a)


@borrowing
def _dash_acceleration(r, s, power, kp):
    """My dash acceleration along the body, limited by the stamina left (docs/rules.md §2, "dash"), the power as I
    believe it acts (``believed_dash_power``). The agents always dash straight ahead, so CURRENT's dash
    direction is not modelled."""
    power = believed_dash_power(power, kp)
    cost = power if power >= 0.0 else -2.0 * power
    cost = min(cost, max(0.0, s.stamina[r] + kp.extra_stamina))
    s.stamina[r] = max(0.0, s.stamina[r] - cost)
    power = cost if power >= 0.0 else -0.5 * cost
    acc = s.effort[r] * power * kp.dash_power_rate
    a = math.radians(s.body[r, s.me[r]])
    return acc * math.cos(a), acc * math.sin(a)


@njit(cache=True, inline="always")
def _move(r, s, obj, ax, ay, accel_max, speed_max, decay):
    """One step of an object (docs/rules.md §1 step 2, no noise)."""
    if ax != 0.0 or ay != 0.0:
        if compared_hypot(ax, ay, accel_max) > accel_max:  # the cap's own arithmetic takes the exact length
            a = math.hypot(ax, ay)
            ax *= accel_max / a
            ay *= accel_max / a
        vx = s.vel[r, obj, 0] + ax
        vy = s.vel[r, obj, 1] + ay
        if compared_hypot(vx, vy, speed_max) > speed_max:
            v = math.hypot(vx, vy)
            vx *= speed_max / v
            vy *= speed_max / v
        s.vel[r, obj, 0] = vx
        s.vel[r, obj, 1] = vy
    s.pos[r, obj, 0] += s.vel[r, obj, 0]
    s.pos[r, obj, 1] += s.vel[r, obj, 1]
    s.vel[r, obj, 0] *= decay
    s.vel[r, obj, 1] *= decay


@borrowing
def _stop_ball_at_opponent(r, s, x0, y0, n_keepers, kp, cfg):
    """The rolled-out ball stops if the usable opponent nearest to where it was (x0, y0) can kick it
    where it is now (C++ ``WorldModel::updateDynamicObjectForNextCycle``, ball branch): he is taken to
    control it."""
    first, last = opponent_range(s.me[r], n_keepers, s.pos.shape[1] - 1)
    opp, _ = _closest_player(r, s, x0, y0, first, last + 1, -1, cfg)
    kickable = kickable_distance(kp)
    if opp >= 0 and compared_hypot(s.pos[r, BALL, 0] - s.pos[r, opp, 0],
                                   s.pos[r, BALL, 1] - s.pos[r, opp, 1], kickable) < kickable:
        s.vel[r, BALL, 0] = 0.0
        s.vel[r, BALL, 1] = 0.0


@borrowing
def predict_row(r: int, s: ModelState, n_keepers: int, kp, cfg) -> None:
    """Advance row ``r`` by one cycle: apply my pending commands and roll every object out. A ball I did
    not kick stops where an opponent can kick it (:func:`_stop_ball_at_opponent`); the other players are
    still at their old estimates then, as in the C++ (the ball is updated first)."""
    s.time[r] += 1
    me = s.me[r]
    main = s.cmd_main[r]
    ax = ay = bx = by = 0.0
    kick = main == CMD_KICK and _ball_kickable_by_me(r, s, kp)
    if main == CMD_DASH:
        ax, ay = _dash_acceleration(r, s, s.cmd_args[r, 0], kp)
    elif main == CMD_TURN:
        speed = math.hypot(s.vel[r, me, 0], s.vel[r, me, 1])
        s.body[r, me] = normalize_angle(s.body[r, me] + turn_effect(s.cmd_args[r, 0], speed, kp))
    elif kick:
        bx, by = _kick_acceleration(r, s, s.cmd_args[r, 0], s.cmd_args[r, 1], kp)
    s.kicked[r] = main == CMD_KICK
    neck_moment = _clamp(s.cmd_args[r, 2], kp.min_neck_moment, kp.max_neck_moment)
    s.neck[r, me] = _clamp(s.neck[r, me] + neck_moment, kp.min_neck_angle, kp.max_neck_angle)
    s.cmd_main[r] = CMD_NONE
    s.cmd_args[r, :] = 0.0

    x0, y0 = s.pos[r, BALL, 0], s.pos[r, BALL, 1]
    _move(r, s, BALL, bx, by, kp.ball_accel_max, kp.ball_speed_max, kp.ball_decay)
    if not kick:
        _stop_ball_at_opponent(r, s, x0, y0, n_keepers, kp, cfg)
    for obj in range(1, s.pos.shape[1]):
        if obj == me:
            _move(r, s, obj, ax, ay, kp.player_accel_max, kp.player_speed_max, kp.player_decay)
        else:
            _move(r, s, obj, 0.0, 0.0, kp.player_accel_max, kp.player_speed_max, kp.player_decay)
            s.err[r, obj] += kp.player_speed_max


@borrowing
def advance_row(r: int, s: ModelState, cycle: int, n_keepers: int, kp, cfg) -> None:
    """Predict row ``r`` forward to ``cycle`` (the first percept just sets the clock)."""
    if s.time[r] < 0:
        s.time[r] = cycle
    while s.time[r] < cycle:
        predict_row(r, s, n_keepers, kp, cfg)


# ---------------------------------------------------------------------------------------------------
# sense_body (docs/rules.md §5.3)


@njit(cache=True, inline="always")
def _sign(x):
    """C++ ``sign`` (Geometry.cc): 1 for positive, else -1 (zero counts as negative)."""
    return 1.0 if x > 0.0 else -1.0


@borrowing
def _sensed_velocity(r, s):
    """My velocity from the last sense_body speed, relative to my current head estimate."""
    me = s.me[r]
    a = math.radians(s.body[r, me] + s.neck[r, me] + _truncated_centre(s.speed[r, 1]))
    return s.speed[r, 0] * math.cos(a), s.speed[r, 0] * math.sin(a)


@borrowing
def _velocity_from_speed(r, s):
    """My velocity from the last sense_body speed."""
    me = s.me[r]
    s.vel[r, me, 0], s.vel[r, me, 1] = _sensed_velocity(r, s)


@borrowing
def _guess_collision(r, s, x, y, vx, vy, nx, ny, kp, cfg):
    """Whether I collided in the last step, guessed from the sensed velocity (nx, ny) as the C++ guesses
    it (``WorldModel::updateAgentAndBallAfterSense``); if so and the ball is nearer to me than any other
    player, the ball is moved out of me (``updateBallForCollision``). (x, y), (vx, vy) is my state the C++
    compares with: predicted after a dash or turn, else (a kick or no command) as it was before the step.
    A collision is guessed when the sensed speed is zero while I was predicted to move with the ball
    within 0.8 m, when the ball overlaps me with zero speed, or when near the ball the speed dropped below
    a quarter of the predicted one with each component flipped or small. A ball not seen since the last
    forget is nowhere (the C++ keeps unknown positions far off the pitch)."""
    # the speeds and the ball's distance meet thresholds (compared_hypot decides each exactly); the
    # exact lengths are taken only where arithmetic needs them
    bdx, bdy = s.pos[r, BALL, 0] - x, s.pos[r, BALL, 1] - y
    ball_known = s.seen[r, BALL] != NEVER
    if compared_hypot(nx, ny, SPEED_EPSILON) < SPEED_EPSILON:  # stopped
        touching = kp.player_size + kp.ball_size
        collided = ball_known and (
            (compared_hypot(vx, vy, COLLISION_MOVING_SPEED) > COLLISION_MOVING_SPEED
             and compared_hypot(bdx, bdy, COLLISION_BALL_NEAR) < COLLISION_BALL_NEAR)
            or compared_hypot(bdx, bdy, touching) < touching)
    else:
        near_ball = kickable_distance(kp) + COLLISION_BALL_MARGIN
        reversed_x = _sign(vx) != _sign(nx) or abs(vx) < COLLISION_SMALL_COMPONENT
        reversed_y = _sign(vy) != _sign(ny) or abs(vy) < COLLISION_SMALL_COMPONENT
        collided = (ball_known and compared_hypot(bdx, bdy, near_ball) < near_ball and reversed_x and reversed_y
                    and math.hypot(nx, ny) < COLLISION_SPEED_DROP * math.hypot(vx, vy))
    if not collided:  # (every collision has the ball near: known)
        return False
    s.collision_time[r] = s.time[r]
    _, d_player = _closest_player(r, s, x, y, 1, s.pos.shape[1], s.me[r], cfg)
    if math.hypot(bdx, bdy) < d_player:
        a = math.atan2(s.pos[r, BALL, 1] - y, s.pos[r, BALL, 0] - x)
        s.pos[r, BALL, 0] = x + COLLISION_BALL_DISTANCE * math.cos(a)
        s.pos[r, BALL, 1] = y + COLLISION_BALL_DISTANCE * math.sin(a)
        s.vel[r, BALL, 0] *= COLLISION_VEL_FACTOR
        s.vel[r, BALL, 1] *= COLLISION_VEL_FACTOR
    return True


@borrowing
def sense_body_row(r: int, s: ModelState, cycle: int, speed_amount: float, speed_dir: float, head_angle: int,
                   stamina: float, effort: float, n_keepers: int, kp, cfg) -> None:
    """Take a sense_body: advance to its cycle, correct my neck (kept if the prediction truncates to
    the reported head_angle), stamina and effort, guess whether I collided (:func:`_guess_collision`), and
    take my velocity from the speed. My position, as the C++ sets it: without a collision, where the
    sensed speed took me from where I was a cycle ago; after one, where my commands were predicted to take
    me (``WorldModel::updateAgentAndBallAfterSense``)."""
    me = s.me[r]
    x0, y0, t0 = s.pos[r, me, 0], s.pos[r, me, 1], s.time[r]
    moved = s.cmd_main[r] == CMD_DASH or s.cmd_main[r] == CMD_TURN
    x, y = x0, y0
    vx, vy = s.vel[r, me, 0], s.vel[r, me, 1]
    advance_row(r, s, cycle, n_keepers, kp, cfg)
    if moved:
        x, y = s.pos[r, me, 0], s.pos[r, me, 1]
        vx, vy = s.vel[r, me, 0], s.vel[r, me, 1]
    if int(s.neck[r, me]) != head_angle:
        s.neck[r, me] = _truncated_centre(float(head_angle))
    s.stamina[r] = stamina
    s.effort[r] = effort
    s.speed[r, 0] = speed_amount
    s.speed[r, 1] = speed_dir
    s.speed_time[r] = cycle
    nx, ny = _sensed_velocity(r, s)
    s.collided[r] = t0 >= 0 and _guess_collision(r, s, x, y, vx, vy, nx, ny, kp, cfg)
    s.vel[r, me, 0], s.vel[r, me, 1] = nx, ny
    if t0 >= 0 and not s.collided[r] and cycle - t0 == 1:
        s.pos[r, me, 0] = x0 + nx / kp.player_decay
        s.pos[r, me, 1] = y0 + ny / kp.player_decay


# ---------------------------------------------------------------------------------------------------
# see (docs/rules.md §5.2)


@njit(cache=True, inline="always")
def _flag_cos_sin(a):
    """cos and sin of a flag's direction ``a`` (degrees): from the table for a whole degree, as the
    server sends, else computed."""
    if -180.0 <= a <= 180.0 and a == math.floor(a):
        k = int(a) + 180
        return _WHOLE_DEGREES[k, 0], _WHOLE_DEGREES[k, 1]
    return math.cos(math.radians(a)), math.sin(math.radians(a))


@borrowing
def localise_row(r: int, s: ModelState, see: SeeBuffer, flag_pos: np.ndarray, kp) -> None:
    """My head direction and position from the seen flags.

    Each flag i gives its position relative to my head, q_i = polar(d_i, dir_i), and its global
    position f_i = p + R(head) q_i. The weighted least-squares (p, head) is a 2-D Procrustes fit: head =
    atan2(sum w (Q x F), sum w (Q . F)) over centred Q, F, then p = mean f - R(head) mean q. Weights are the
    inverse quantisation variances, so near flags dominate the position and far ones add baseline to
    the direction. One flag keeps the predicted head. The correction of my predicted position is kept
    in ``loc_shift`` (the ball's position differences discount it).
    """
    n = see.n_flags[r]
    s.loc_shift[r, :] = 0.0
    if n == 0:
        return
    me = s.me[r]
    sw = mqx = mqy = mfx = mfy = 0.0
    for i in range(n):
        d = see.flag_obs[r, i, 0]
        w = _flag_weight(d, kp)
        ca, sa = _flag_cos_sin(see.flag_obs[r, i, 1])
        see.flag_q[r, i, 0] = w  # kept for the second pass
        see.flag_q[r, i, 1] = d * ca
        see.flag_q[r, i, 2] = d * sa
        sw += w
        mqx += w * d * ca
        mqy += w * d * sa
        mfx += w * flag_pos[see.flag_id[r, i], 0]
        mfy += w * flag_pos[see.flag_id[r, i], 1]
    mqx /= sw
    mqy /= sw
    mfx /= sw
    mfy /= sw
    if n >= 2:
        dot = cross = 0.0
        for i in range(n):
            w = see.flag_q[r, i, 0]
            qx = see.flag_q[r, i, 1] - mqx
            qy = see.flag_q[r, i, 2] - mqy
            fx = flag_pos[see.flag_id[r, i], 0] - mfx
            fy = flag_pos[see.flag_id[r, i], 1] - mfy
            dot += w * (qx * fx + qy * fy)
            cross += w * (qx * fy - qy * fx)
        head = math.degrees(math.atan2(cross, dot))
    else:
        head = s.body[r, me] + s.neck[r, me]
    h = math.radians(head)
    c = math.cos(h)
    sn = math.sin(h)
    x = mfx - (c * mqx - sn * mqy)
    y = mfy - (sn * mqx + c * mqy)
    s.loc_shift[r, 0] = x - s.pos[r, me, 0]
    s.loc_shift[r, 1] = y - s.pos[r, me, 1]
    s.pos[r, me, 0] = x
    s.pos[r, me, 1] = y
    s.body[r, me] = normalize_angle(head - s.neck[r, me])
    s.err[r, me] = 0.0
    s.seen[r, me] = s.time[r]


@borrowing
def _seen_point(r, s, dist, direction):
    """Global position of a polar observation relative to my head, and the unit sight vector."""
    me = s.me[r]
    a = math.radians(s.body[r, me] + s.neck[r, me] + direction)
    ex = math.cos(a)
    ey = math.sin(a)
    return s.pos[r, me, 0] + dist * ex, s.pos[r, me, 1] + dist * ey, ex, ey


@borrowing
def _change_velocity(r, s, dist, ex, ey, dist_chg, dir_chg):
    """Velocity from the change pair: v = v_me + dist_chg e + rad(dir_chg) d e_perp (docs/rules.md §5.2)."""
    me = s.me[r]
    tangential = math.radians(dir_chg) * dist
    return (s.vel[r, me, 0] + dist_chg * ex - tangential * ey,
            s.vel[r, me, 1] + dist_chg * ey + tangential * ex)


@borrowing
def _mark_seen(r, s, obj, px, py):
    """Object ``obj`` seen at (px, py) now."""
    s.pos[r, obj, 0] = px
    s.pos[r, obj, 1] = py
    s.obs_pos[r, obj, 0] = px
    s.obs_pos[r, obj, 1] = py
    s.obs_time[r, obj] = s.time[r]
    s.seen[r, obj] = s.time[r]
    s.err[r, obj] = 0.0


@borrowing
def _ball_velocity_from_positions(r, s, px, py, vx, vy, kp, cfg):
    """The ball's velocity from its last seen position (C++ ``calculateStateBall`` without the change
    pair): seen 1 cycle ago, v = (p1 - p0) d; 2 cycles ago, v0 = (p1 - p0) d/(1 + d) and v = v0 d unless
    a player (me included) was within kickable distance of the ball's position a cycle ago, or I kicked,
    or collided within 3 cycles; otherwise, or after a collision at the last sense, the predicted
    (vx, vy) stays. The displacement discounts my own localisation correction (``loc_shift``): both
    positions then carry the same error of my position.
    """
    if s.collided[r]:
        return vx, vy
    d = kp.ball_decay
    gap = s.time[r] - s.obs_time[r, BALL]
    dx = px - s.obs_pos[r, BALL, 0] - s.loc_shift[r, 0]
    dy = py - s.obs_pos[r, BALL, 1] - s.loc_shift[r, 1]
    if gap == 1:
        return dx * d, dy * d
    if gap == 2:
        tx = dx / (1.0 + d) * d
        ty = dy / (1.0 + d) * d
        _, near = _closest_player(r, s, px - tx, py - ty, 1, s.pos.shape[1], -1, cfg)
        if (near > kickable_distance(kp) and not s.kicked[r]
                and s.time[r] - s.collision_time[r] > POSITION_DIFF_COLLISION_CYCLES):
            return tx * d, ty * d
    return vx, vy


@borrowing
def _opponent_controls_ball(r, s, px, py, my_dist, n_keepers, kp, cfg):
    """A usable opponent is within kickable distance of the ball at (px, py) and I (``my_dist`` from it)
    am not: he controls it, and the C++ believes it still (``calculateStateBall``)."""
    first, last = opponent_range(s.me[r], n_keepers, s.pos.shape[1] - 1)
    _, d_opp = _closest_player(r, s, px, py, first, last + 1, -1, cfg)
    kickable = kickable_distance(kp)
    return d_opp < kickable and my_dist > kickable


@borrowing
def hold_exact_ball_row(r: int, s: ModelState, n_keepers: int, kp, cfg) -> None:
    """The rule of :func:`update_ball_row` on an exact (fullstate) ball: still if an opponent controls it. Not
    in the C++, whose fullstate skips its see rules; without it takers with the exact state chase every small
    kick of a keeper that holds the ball and turn for ever (docs/design.md, "The ball in the players' world
    model")."""
    me = s.me[r]
    bx, by = s.pos[r, BALL, 0], s.pos[r, BALL, 1]
    if _opponent_controls_ball(r, s, bx, by, math.hypot(bx - s.pos[r, me, 0], by - s.pos[r, me, 1]),
                               n_keepers, kp, cfg):
        s.vel[r, BALL, 0] = 0.0
        s.vel[r, BALL, 1] = 0.0


@borrowing
def update_ball_row(r: int, s: ModelState, see: SeeBuffer, n_keepers: int, kp, cfg) -> None:
    """The ball from the see (docs/rules.md §5.2), as the C++ ``WorldModel::calculateStateBall``: the velocity from
    the change pair, averaged with the predicted one if each component is within 2 ball_rand |v_pred| of
    it; without the pair, within visible_distance, from successive positions
    (:func:`_ball_velocity_from_positions`); else the predicted one. Then zero if a usable opponent is
    within kickable distance of the ball and I am not (he controls it), else at most ball_speed_max if
    above (1 + ball_rand) ball_speed_max. Call after the players are updated: the opponents' positions are
    this see's."""
    if not see.ball_seen[r]:
        return
    dist, direction = see.ball_obs[r, 0], see.ball_obs[r, 1]
    dist_chg, dir_chg = see.ball_obs[r, 2], see.ball_obs[r, 3]
    px, py, ex, ey = _seen_point(r, s, dist, direction)
    vx, vy = s.vel[r, BALL, 0], s.vel[r, BALL, 1]
    if not (math.isnan(dist_chg) or math.isnan(dir_chg)):
        s.ball_chg[r] = s.time[r]
        cx, cy = _change_velocity(r, s, dist, ex, ey, dist_chg, dir_chg)
        agree = 2.0 * kp.ball_rand * math.hypot(vx, vy)
        if abs(cx - vx) <= agree and abs(cy - vy) <= agree:
            vx, vy = 0.5 * (cx + vx), 0.5 * (cy + vy)
        else:
            vx, vy = cx, cy
    elif dist < kp.visible_distance:
        vx, vy = _ball_velocity_from_positions(r, s, px, py, vx, vy, kp, cfg)
    too_fast = (1.0 + kp.ball_rand) * kp.ball_speed_max
    if _opponent_controls_ball(r, s, px, py, dist, n_keepers, kp, cfg):
        vx = vy = 0.0
    elif compared_hypot(vx, vy, too_fast) > too_fast:
        speed = math.hypot(vx, vy)
        vx *= kp.ball_speed_max / speed
        vy *= kp.ball_speed_max / speed
    s.vel[r, BALL, 0] = vx
    s.vel[r, BALL, 1] = vy
    _mark_seen(r, s, BALL, px, py)


@borrowing
def _compatible(obj, side, n_keepers):
    """Can object ``obj`` be a player of ``side`` (-1: unknown side)? Keepers are 'l' (0), takers 'r'."""
    if side < 0:
        return True
    return (obj <= n_keepers) == (side == 0)


@borrowing
def associate_row(r: int, s: ModelState, see: SeeBuffer, n_keepers: int, kp) -> None:
    """Object index of every player observation of the see, in ``see.target[r]``.

    Named observations (side and unum) map directly. Each remaining one goes to the nearest compatible
    predicted player not yet taken (greedy over the smallest cost). Distances are measured in units of
    what the player could have moved since seen plus the quantisation error of two observations, along
    and across the line of sight separately (seen distances are far less precise than directions). A
    player within those bounds costs its normalised distance; a never-seen player costs _UNSEEN_COST;
    a seen player out of bounds costs more still.
    """
    me = s.me[r]
    n_obj = s.pos.shape[1]
    taken = see.taken[r]
    taken[:] = False
    taken[BALL] = True
    taken[me] = True
    head = math.radians(s.body[r, me] + s.neck[r, me])
    n = see.n_players[r]
    for i in range(n):
        see.target[r, i] = -1
        side = see.player_side[r, i]
        unum = see.player_unum[r, i]
        if side >= 0 and unum != _NO_UNUM:
            obj = unum if side == 0 else n_keepers + unum
            if 0 < obj < n_obj and not taken[obj]:
                see.target[r, i] = obj
                taken[obj] = True
    for i in range(n):
        if see.target[r, i] >= 0:
            continue
        d = see.player_obs[r, i, 0]
        a = head + math.radians(see.player_obs[r, i, 1])
        ex = math.cos(a)
        ey = math.sin(a)
        px = s.pos[r, me, 0] + d * ex
        py = s.pos[r, me, 1] + d * ey
        radial, lateral = _observation_bounds(d, kp.quantize_step)
        for obj in range(n_obj):
            cost = np.inf
            if not taken[obj] and _compatible(obj, see.player_side[r, i], n_keepers):
                if s.seen[r, obj] == NEVER:
                    cost = _UNSEEN_COST
                else:
                    dx = s.pos[r, obj, 0] - px
                    dy = s.pos[r, obj, 1] - py
                    along = abs(dx * ex + dy * ey) / (s.err[r, obj] + 2.0 * radial)
                    across = abs(dx * ey - dy * ex) / (s.err[r, obj] + 2.0 * lateral)
                    cost = math.hypot(along, across)
                    if max(along, across) > 1.0:
                        cost += 2.0 * _UNSEEN_COST
            see.cost[r, i, obj] = cost
    while True:
        best = np.inf
        bi = bo = -1
        for i in range(n):
            if see.target[r, i] >= 0:
                continue
            for obj in range(n_obj):
                if see.cost[r, i, obj] < best:
                    best = see.cost[r, i, obj]
                    bi = i
                    bo = obj
        if bi < 0:
            break
        see.target[r, bi] = bo
        for i in range(n):
            see.cost[r, i, bo] = np.inf


@borrowing
def update_players_row(r: int, s: ModelState, see: SeeBuffer, n_keepers: int, kp) -> None:
    """The other players from the see: association, then position, change-pair velocity (else the
    predicted one stays), facing."""
    associate_row(r, s, see, n_keepers, kp)
    me = s.me[r]
    head = s.body[r, me] + s.neck[r, me]
    for i in range(see.n_players[r]):
        obj = see.target[r, i]
        if obj < 0:
            continue
        o = see.player_obs[r, i]
        px, py, ex, ey = _seen_point(r, s, o[0], o[1])
        if not (math.isnan(o[2]) or math.isnan(o[3])):
            s.vel[r, obj, 0], s.vel[r, obj, 1] = _change_velocity(r, s, o[0], ex, ey, o[2], o[3])
        _mark_seen(r, s, obj, px, py)
        if not math.isnan(o[4]):
            s.body[r, obj] = normalize_angle(head + o[4])
            if not math.isnan(o[5]):
                s.neck[r, obj] = normalize_angle(o[5] - o[4])


@borrowing
def see_row(r: int, s: ModelState, see: SeeBuffer, flag_pos: np.ndarray, n_keepers: int, kp, cfg) -> None:
    """Take the see of row ``r``: advance to its cycle, localise, then the players and the ball (the
    C++ ``WorldModel::updateAfterSeeMessage`` order, which the ball's rules rely on). A see older than the
    estimate is ignored."""
    cycle = see.cycle[r]
    if cycle < 0 or cycle < s.time[r]:
        return
    advance_row(r, s, cycle, n_keepers, kp, cfg)
    localise_row(r, s, see, flag_pos, kp)
    if s.speed_time[r] == s.time[r]:
        _velocity_from_speed(r, s)
    update_players_row(r, s, see, n_keepers, kp)
    update_ball_row(r, s, see, n_keepers, kp, cfg)


@borrowing(inline="always")
def sent_row(r: int, s: ModelState, main: int, a1: float, a2: float, neck: float) -> None:
    """The commands row ``r`` sent this cycle (a CMD_* code of ``core/objects.py`` with its two arguments, and
    the turn_neck moment, 0 for none): the next step's prediction applies them (``predict_row``)."""
    s.cmd_main[r] = main
    s.cmd_args[r, 0] = a1
    s.cmd_args[r, 1] = a2
    s.cmd_args[r, 2] = neck


@borrowing
def forget_row(r: int, s: ModelState) -> None:
    """Episode boundary (`training Keepaway 1`, docs/players.md §4.2): every object but me is
    unknown again."""
    me = s.me[r]
    for obj in range(s.pos.shape[1]):
        if obj != me:
            s.seen[r, obj] = NEVER
            s.obs_time[r, obj] = NEVER
            s.vel[r, obj, 0] = 0.0
            s.vel[r, obj, 1] = 0.0
            s.err[r, obj] = 0.0


@borrowing
def write_belief_row(r: int, s: ModelState, out: Belief, row: int) -> None:
    """Row ``row`` of the belief ``out`` from row ``r`` of the model; conf = 1 - age/100, 1 for me."""
    me = s.me[r]
    out.time[row] = s.time[r]
    out.me[row] = me
    out.effort[row] = s.effort[r]
    for obj in range(s.pos.shape[1]):
        out.pos[row, obj, 0] = s.pos[r, obj, 0]
        out.pos[row, obj, 1] = s.pos[r, obj, 1]
        out.vel[row, obj, 0] = s.vel[r, obj, 0]
        out.vel[row, obj, 1] = s.vel[r, obj, 1]
        out.body[row, obj] = s.body[r, obj]
        out.neck[row, obj] = s.neck[r, obj]
        out.conf[row, obj] = confidence(r, s, obj)


# ---------------------------------------------------------------------------------------------------
# the per-process wrapper


@borrowing
def frame_row(buf, end: int, s: ModelState, see: SeeBuffer, flag_pos: np.ndarray, values: np.ndarray, exact_cycle: int,
              n_keepers: int, kp, cfg) -> tuple:
    """The frame ``buf[:end]`` read by ``agents.frames.decode_frame`` (a see into row 0 of ``see``, other
    values into ``values``) and, if it is a see or sense_body of another cycle than ``exact_cycle`` (a
    fullstate's), taken into model row 0 as :func:`see_row` and :func:`sense_body_row` take them; a hear's
    or think's values are left in ``values``. Returns decode_frame's (kind, cycle)."""
    kind, cycle = decode_frame(buf, end, 0, see, flag_pos.shape[0], values)
    if cycle != exact_cycle:
        if kind == SEE:
            see_row(0, s, see, flag_pos, n_keepers, kp, cfg)
        elif kind == SENSE_BODY:
            sense_body_row(0, s, cycle, values[SPEED_AMOUNT], values[SPEED_DIRECTION], int(values[HEAD_ANGLE]),
                           values[STAMINA], values[EFFORT], n_keepers, kp, cfg)
    return kind, cycle


class WorldModel:
    """The world model of one player process (B = 1): feed it the decoded percepts of each cycle and
    the commands sent, read :meth:`belief` before deciding.

    ``flags`` is the landmark table of ``init_ok`` (``[[name, x, y], ...]``): see flag ids index it.
    Keepers are side 'l', takers side 'r' (docs/players.md §1); ``me`` follows `core/objects.py`.
    ``config``: the players' settings (default ``AgentConfig()``), of which the ball rules use
    ``player_conf_threshold``.
    """

    def __init__(self, params: ServerParams, side: str, unum: int, n_keepers: int, n_takers: int,
                 flags: Sequence[Sequence[Any]], config: AgentConfig | None = None) -> None:
        if side not in SIDE_CODES:
            raise ValueError(f"unknown side {side!r}")
        limit = n_keepers if side == "l" else n_takers
        if not 1 <= unum <= limit:
            raise ValueError(f"no player {side} {unum} with {n_keepers} keepers and {n_takers} takers")
        self.kp = params.kernel()
        self.cfg = (config or AgentConfig()).kernel()
        self.n_keepers = n_keepers
        self.n_takers = n_takers
        self.me = unum if side == "l" else n_keepers + unum
        self.flag_pos = np.array([[f[1], f[2]] for f in flags], dtype=np.float64).reshape(-1, 2)
        # read-only like protocol.landmarks.FLAG_POSITIONS, which the batched mode passes: numba types
        # the two alike, so both modes load one compiled see_row
        self.flag_pos.setflags(write=False)
        self.state = new_model_state(1, n_keepers, n_takers, self.me, params)
        self.see_buffer = new_see_buffer(1, len(self.flag_pos), 1 + n_keepers + n_takers)
        self.belief_rows = empty_belief(1, n_keepers, n_takers)  # what belief() writes (and agents.think)
        self._exact_cycle = -1
        # the kernels of every percept, called without numba's typing of their arguments at each call
        self._sense_body_row = SteadyCall(sense_body_row)
        self._see_row = SteadyCall(see_row)
        self._hold_exact_ball_row = SteadyCall(hold_exact_ball_row)
        self._write_belief_row = SteadyCall(write_belief_row)
        self._frame_row = SteadyCall(frame_row)
        self.frame_values = np.zeros(FRAME_VALUES)  # the values of the last frame on_frame read

    def _is_exact(self, msg: Mapping[str, Any]) -> bool:
        """Whether a fullstate already gave the exact state of the message's cycle."""
        return int(msg["cycle"]) == self._exact_cycle

    def on_sense_body(self, msg: Mapping[str, Any]) -> None:
        """A sense_body payload (docs/rules.md §5.3): my neck, velocity, stamina and effort of its cycle."""
        cycle = int(msg["cycle"])
        if cycle == self._exact_cycle:
            return
        speed, stamina = msg["speed"], msg["stamina"]
        self._sense_body_row(0, self.state, cycle, float(speed[0]), float(speed[1]), int(msg["head_angle"]),
                             float(stamina[0]), float(stamina[1]), self.n_keepers, self.kp, self.cfg)

    def on_see(self, msg: Mapping[str, Any]) -> None:
        """A see payload (docs/rules.md §5.2): anonymous flags are skipped, and so are flags whose id lies beyond
        init_ok's landmark table (the protocol allows ids up to 255: a server that sends one has no
        position for it); omitted fields become NaN."""
        if self._is_exact(msg):
            return
        buf = self.see_buffer
        landmarks = len(self.flag_pos)
        flags = [f for f in msg["flags"] if f[0] is not None and f[0] < landmarks]
        n = len(flags)
        buf.n_flags[0] = n
        if n:
            rows = np.array([f[:3] for f in flags], dtype=np.float64)
            buf.flag_id[0, :n] = rows[:, 0]
            buf.flag_obs[0, :n] = rows[:, 1:]
        ball = msg["ball"]
        buf.ball_seen[0] = ball is not None
        if ball is not None:
            buf.ball_obs[0] = [np.nan if v is None else v for v in ball]
        players = msg["players"][: buf.player_obs.shape[1]]
        n = len(players)
        buf.n_players[0] = n
        if n:
            buf.player_side[0, :n] = [SIDE_CODES.get(p[0], _NO_SIDE) for p in players]
            buf.player_unum[0, :n] = [_NO_UNUM if p[1] is None else p[1] for p in players]
            buf.player_obs[0, :n] = [[np.nan if v is None else v for v in p[2:]] for p in players]
        buf.cycle[0] = int(msg["cycle"])
        self._see_row(0, self.state, buf, self.flag_pos, self.n_keepers, self.kp, self.cfg)

    def on_frame(self, data: bytes) -> tuple[int, int]:
        """A frame's msgpack bytes, read by ``agents.frames.decode_frame`` if it is in the form that kernel
        takes (every see, sense_body, player's hear and think the server sends is), in one kernel call
        (:func:`frame_row`): returns (kind, cycle),
        the kind an index of ``agents.frames.FRAME_TYPES``. A see or sense_body is taken as :meth:`on_see`
        or :meth:`on_sense_body` takes the decoded message; a hear's or think's values are left in
        :attr:`frame_values` for the agent. Returns (``NOT_TAKEN``, -1) for any other frame, which is then
        the caller's to decode in full, and this model is as it was but for the see buffer's scratch."""
        if type(data) is not bytes:
            data = bytes(data)  # the kernel takes the frame as bytes (core.msgpack_in)
        size = len(data)
        if size > FRAME_BYTES:
            return NOT_TAKEN, -1
        return self._frame_row(data, size, self.state, self.see_buffer, self.flag_pos, self.frame_values,
                               self._exact_cycle, self.n_keepers, self.kp, self.cfg)

    def on_fullstate(self, msg: Mapping[str, Any]) -> None:
        """Exact state (docs/rules.md §5.4): every object known exactly at the message's cycle; percepts
        of the same cycle are then ignored."""
        s = self.state
        cycle = int(msg["cycle"])
        self._exact_cycle = cycle
        s.time[0] = cycle
        s.pos[0, BALL] = msg["ball"][:2]
        s.vel[0, BALL] = msg["ball"][2:4]
        for p in msg["players"]:
            obj = p[1] if p[0] == "l" else self.n_keepers + p[1]
            s.pos[0, obj] = p[2:4]
            s.vel[0, obj] = p[4:6]
            s.body[0, obj] = p[6]
            s.neck[0, obj] = p[7]
            if obj == self.me:
                s.stamina[0] = p[8]
                s.effort[0] = p[9]
        s.seen[0, :] = cycle
        s.obs_pos[0] = s.pos[0]
        s.obs_time[0, :] = cycle
        s.ball_chg[0] = cycle
        s.err[0, :] = 0.0
        self._hold_exact_ball_row(0, s, self.n_keepers, self.kp, self.cfg)

    def on_own_commands(self, main: int, a1: float, a2: float, neck: float = 0.0) -> None:
        """The commands I sent this cycle (:func:`sent_row`)."""
        sent_row(0, self.state, int(main), float(a1), float(a2), float(neck))

    def forget(self) -> None:
        """Episode boundary: forget every object but me."""
        forget_row(0, self.state)

    def belief(self) -> Belief:
        """The current belief (B = 1). The arrays are reused: copy them to keep a snapshot."""
        self._write_belief_row(0, self.state, self.belief_rows, 0)
        return self.belief_rows


__all__ = [
    "CONF_HORIZON_CYCLES",
    "ModelState",
    "SeeBuffer",
    "WorldModel",
    "advance_row",
    "associate_row",
    "confidence",
    "forget_row",
    "frame_row",
    "localise_row",
    "new_model_state",
    "new_see_buffer",
    "predict_row",
    "see_row",
    "sense_body_row",
    "sent_row",
    "update_ball_row",
    "update_players_row",
    "whole_degree_table",
    "write_belief_row",
]
