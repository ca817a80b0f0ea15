"""Interception: who reaches the ball first, where I meet it, and the moves that take me there.

The keepaway-framework's intercept (docs/players.md §4.3, §5.2): the travel-time simulation that decides who
is fastest to the ball, the interception point with its stability rule, the close interception
(``BasicPlayer::interceptClose``, keepaway-0.6 player/BasicPlayer.cc) and the move towards the point
(``predictCommandToMoveToPos``, ``predictCommandToInterceptBall``, keepaway-0.6 player/WorldModelPredict.cc).
Skills as in `agents/movement.py`: kernels on a belief row that return a command triple.
"""

from __future__ import annotations

import math

import numpy as np

from keepaway.agents.belief import AgentMemory, Belief
from keepaway.agents.geometry import (
    DECIDE_SLACK,
    ball_in,
    compared_hypot,
    dash_power_along,
    dash_power_for,
    dash_velocity,
    direction,
    distance,
    final_position,
    forward_angle,
    geometric_sum,
    kickable_distance,
    near,
    normalize_angle,
    opponents,
    own_frame_sign,
    player_step,
    rolled_out,
    turn_effect,
    turn_moment,
)
from keepaway.agents.movement import turn_to_point
from keepaway.core.jit import borrowing, njit
from keepaway.core.objects import CMD_DASH, CMD_TURN


@borrowing
def _turn_reach(far: float, kp, cfg) -> float:
    """How far off my body line a point ``far`` away may lie before a move towards it turns first: ratio x
    kickable distance, the ratio 0.9 within 10 m, 2 within 20 m, 3 beyond (``intercept_move``)."""
    if far > cfg.turn_far_distance:
        ratio = cfg.turn_ratio_far
    elif far > cfg.turn_mid_distance:
        ratio = cfg.turn_ratio_mid
    else:
        ratio = cfg.turn_ratio_near
    return ratio * kickable_distance(kp)


@borrowing
def _intercept_turns(
    px: float, py: float, vx: float, vy: float, body: float, tx: float, ty: float, far: float, roll: float,
    cycles: float, kp, cfg,
) -> tuple:
    """(turn?, angle): ``intercept_move``'s choice between a turn by ``angle`` and a dash, given ``far``
    = distance(p, t) and ``roll`` = geometric_sum(player_decay, min(cycles, 4)), which the travel
    simulation reuses (WorldModel::predictCommandTurnTowards without a backward move).

    A turn is due when the point lies more than ratio x kickable distance off the body line through my
    rolled-out position, or behind me beyond the back distance. When more than one turn would be needed
    (the framework simulates up to 5, its velocity decaying), the point is within the back distance and
    is to be reached in fewer than 4 cycles, the player turns its back to it instead if that puts it within
    0.9 x kickable distance of the body line (the next dash then goes backwards, as the players believe
    it can: ``geometry.believed_dash_power``)."""
    qx, qy = px + vx * roll, py + vy * roll
    to_point = direction(tx - qx, ty - qy)
    angle = normalize_angle(to_point - body)
    ahead = distance(qx, qy, tx, ty)
    reach = _turn_reach(far, kp, cfg)
    back_distance = cfg.intercept_back_distance
    far_behind = ahead > back_distance
    if not (ahead * abs(math.sin(math.radians(angle))) > reach or (far_behind and abs(angle) > 90.0)):
        return False, angle
    if ahead >= back_distance or cycles >= cfg.back_turn_max_cycles:
        return True, angle
    speed = math.hypot(vx, vy)
    sb, turns = body, 0
    while turns < cfg.max_sim_turns:
        a = normalize_angle(to_point - sb)
        if not ahead * abs(math.sin(math.radians(a))) > reach:
            break
        sb = normalize_angle(sb + turn_effect(turn_moment(a, speed, kp), speed, kp))
        speed *= kp.player_decay
        turns += 1
    if turns > 1:
        back = normalize_angle(to_point + 180.0 - body)
        speed = math.hypot(vx, vy)
        turned = normalize_angle(body + turn_effect(turn_moment(back, speed, kp), speed, kp))
        if ahead * abs(math.sin(math.radians(to_point - turned))) < cfg.back_turn_margin * kickable_distance(kp):
            return True, back
    return True, angle


@borrowing
def _clearly_dash(qx: float, qy: float, cs: float, sn: float, tx: float, ty: float, far: float, kp, cfg) -> bool:
    """Whether ``_intercept_turns`` would dash, told without its atan2, sine and hypot where the answer
    is clear: (qx, qy) is my rolled-out position, (cs, sn) my body's cosine and sine, ``far`` my distance
    to the point. The point lies off my body line by |d x body| = ahead |sin(angle)| and ahead of me by
    d . body = ahead cos(angle); when each test is more than DECIDE_SLACK from its threshold these decide
    as the exact angle does. False means undecided (the caller asks ``_intercept_turns``)."""
    dx, dy = tx - qx, ty - qy
    ahead = math.sqrt(dx * dx + dy * dy)
    if not ahead > DECIDE_SLACK:
        return False
    if not abs(dx * sn - dy * cs) < _turn_reach(far, kp, cfg) - DECIDE_SLACK:
        return False
    return dx * cs + dy * sn > DECIDE_SLACK or ahead < cfg.intercept_back_distance - DECIDE_SLACK


@borrowing
def intercept_move(
    px: float, py: float, vx: float, vy: float, body: float, effort: float,
    tx: float, ty: float, cycles: float, kp, cfg,
) -> tuple:
    """One move towards an interception point to be reached in ``cycles`` cycles, as the framework's intercept
    and travel-time code moves (WorldModel::predictCommandToMoveToPos with back distance 2.5; docs/players.md
    §5.2 steps 2-3 describe it as the GoToPoint rule, the code uses this one): from my position rolled out
    min(cycles, 4) cycles, turn towards the point only if it lies more than ratio x kickable distance off my
    body line (ratio 0.9 within 10 m, 2 within 20 m, 3 beyond) or behind me beyond 2.5 m, or turn my back to a
    close point (``_intercept_turns``); else dash (backwards if it is behind) with the power that covers the
    distance in ``cycles``. (The code's angle threshold never applies there: an operator-precedence slip makes
    it 180.) Returns (code, arg1)."""
    roll = geometric_sum(kp.player_decay, min(cycles, cfg.intercept_roll_cycles))
    turn, angle = _intercept_turns(
        px, py, vx, vy, body, tx, ty, distance(px, py, tx, ty), roll, cycles, kp, cfg
    )
    if turn:
        return CMD_TURN, turn_moment(angle, math.hypot(vx, vy), kp)
    return CMD_DASH, dash_power_for(tx - px, ty - py, body, vx, vy, effort, cycles, kp)


@njit(cache=True)
def decay_sums(kp, cfg) -> np.ndarray:
    """The table of geometric_sum(player_decay, k) for k = 0..horizon that the travel simulations read
    instead of a pow per step: made once for a game's players (``runner.batched.Players``,
    ``agents.player.PlayerAgent``) and handed down their decisions as ``sums``. The numbers are
    geometric_sum's own."""
    sums = np.empty(int(cfg.intercept_horizon) + 1)
    for k in range(sums.shape[0]):
        sums[k] = geometric_sum(kp.player_decay, float(k))
    return sums


@borrowing
def _decay_sum(sums, k: int, kp) -> float:
    """geometric_sum(player_decay, float(k)) through the table ``sums`` (``decay_sums``)."""
    if k >= sums.shape[0]:
        return geometric_sum(kp.player_decay, float(k))
    return sums[k]


# Relative and absolute slack of travel's out-of-reach test: far above the rounding of a few dozen
# position updates, far below any distance that matters.
_REACH_SLACK = 1.0e-9


@borrowing
def _longest_run(speed: float, left: int, effort: float, sums, kp) -> float:
    """An upper bound on the distance a player moving at ``speed`` covers in its next ``left`` moves, each a
    dash or a turn (``travel``'s out-of-reach test). A move's step is the velocity after the command:
    a dash adds at most a = effort x the largest believed power x dash_power_rate (capped at
    player_accel_max) and caps the speed at player_speed_max, a turn adds nothing; then the velocity
    decays by d = player_decay. So the first step is at most u1 = max(speed, min(player_speed_max,
    speed + a)) and each next one at most d x the last + a, which sums to left A + (u1 - A)(1 - d^left)
    / (1 - d), A = a / (1 - d), A the speed that dashing at full power settles to (1.0 of the 1.2 m the
    cap allows, with the classic parameters). The smaller of that and left x max(player_speed_max, speed)
    (each step within the cap, or the speed there is) is the bound: both hold for any commands."""
    cap = kp.player_speed_max
    flat = left * max(cap, speed)
    acc = min(kp.player_accel_max, effort * max(abs(kp.min_power), abs(kp.max_dash_power)) * kp.dash_power_rate)
    settled = acc / (1.0 - kp.player_decay)
    first = max(speed, min(cap, speed + acc))
    return min(flat, left * settled + (first - settled) * _decay_sum(sums, left, kp))


@borrowing
def _out_of_reach(far: float, speed: float, radius: float, left: int, effort: float, sums, kp) -> bool:
    """far - radius > the longest run in ``left`` moves at ``speed`` (``_longest_run``): the target is
    out of reach for good (``travel``'s test, made for every player at every cycle of an interception
    search). ``far`` and ``speed`` may be sqrt estimates: the bound carries a relative and an absolute
    slack far above their rounding, so an estimate stops only a simulation that the exact distance and
    speed would stop as well."""
    return far - radius > _longest_run(speed, left, effort, sums, kp) * (1.0 + _REACH_SLACK) + _REACH_SLACK


@borrowing
def travel(
    px: float, py: float, vx: float, vy: float, body: float, effort: float,
    tx: float, ty: float, radius: float, n: int, need_end: bool, sums, kp, cfg,
) -> tuple:
    """Simulate ``n`` intercept moves towards (tx, ty), paced to arrive after n cycles (docs/players.md
    §4.3, §5.2 step 2). Returns (first cycle at which the player is within ``radius``, or n + 1; distance after
    n commands). Turns and dashes are counted alike; 0 if already within ``radius``.

    The moves are ``intercept_move`` then ``player_step``, fused: the decay sums come from ``sums``
    (``decay_sums``), the body's cosine and sine are kept between turns; the arithmetic is the same, so
    are the numbers. The simulation stops with (n + 1, inf) as soon as the target is out of reach:
    farther than the longest run the cycles left allow from the current speed (``_longest_run``), which
    is what a full simulation would return too (its distance is read only when the target is reached).
    Without ``need_end`` it also stops at the first cycle within ``radius`` (distance NaN)."""
    reached = n + 1
    dx, dy = tx - px, ty - py
    if _out_of_reach(math.sqrt(dx * dx + dy * dy), math.sqrt(vx * vx + vy * vy), radius, n, effort, sums, kp):
        return reached, math.inf
    roll_limit = cfg.intercept_roll_cycles
    roll_far = 0.0
    if n >= roll_limit:  # through the table when it holds it (the same number)
        whole = int(roll_limit)
        roll_far = _decay_sum(sums, whole, kp) if whole == roll_limit else geometric_sum(kp.player_decay, roll_limit)
    rad = math.radians(body)
    cs, sn = math.cos(rad), math.sin(rad)
    for c in range(n + 1):
        # far and speed only meet thresholds (and speed a turn's arithmetic): a sqrt estimate stands for
        # the exact hypot unless it lies within a hair of a threshold (geometry.near), so the comparisons
        # come out as the exact ones would, and so do the games
        dx, dy = tx - px, ty - py
        far = math.sqrt(dx * dx + dy * dy)
        if near(far, radius) or near(far, cfg.turn_far_distance) or near(far, cfg.turn_mid_distance):
            far = math.hypot(dx, dy)
        if reached > n and far < radius:
            reached = c
            if not need_end:
                return reached, math.nan
        if c == n:
            break
        left = n - c
        if reached > n and c > 0:  # c = 0 was tested above
            speed = math.sqrt(vx * vx + vy * vy)
            if _out_of_reach(far, speed, radius, left, effort, sums, kp):
                return n + 1, math.inf
        roll = _decay_sum(sums, left, kp) if left < roll_limit else roll_far
        turn, angle = False, 0.0
        if not _clearly_dash(px + vx * roll, py + vy * roll, cs, sn, tx, ty, far, kp, cfg):
            turn, angle = _intercept_turns(px, py, vx, vy, body, tx, ty, far, roll, float(left), kp, cfg)
        if turn:
            speed = math.hypot(vx, vy)  # the turn's arithmetic takes the exact speed
            body = normalize_angle(body + turn_effect(turn_moment(angle, speed, kp), speed, kp))
            rad = math.radians(body)
            cs, sn = math.cos(rad), math.sin(rad)
        else:
            power = dash_power_along(tx - px, ty - py, cs, sn, vx, vy, effort, _decay_sum(sums, left, kp), kp)
            vx, vy = dash_velocity(vx, vy, cs, sn, effort, power, kp)
        px += vx
        py += vy
        vx, vy = vx * kp.player_decay, vy * kp.player_decay
    return reached, distance(px, py, tx, ty)


@borrowing
def player_travel(bel: Belief, r: int, obj: int, tx: float, ty: float, n: int, need_end: bool, sums, kp,
                  cfg) -> tuple:
    """``travel`` for player ``obj`` of row ``r`` to within kickable distance of (tx, ty); my own effort is
    known, the others' is assumed at its initial value."""
    effort = bel.effort[r] if obj == bel.me[r] else kp.effort_init
    return travel(
        bel.pos[r, obj, 0], bel.pos[r, obj, 1], bel.vel[r, obj, 0], bel.vel[r, obj, 1], bel.body[r, obj],
        effort, tx, ty, kickable_distance(kp), n, need_end, sums, kp, cfg,
    )


@borrowing
def fastest_to_ball(bel: Belief, r: int, first: int, last: int, sums, kp, cfg) -> tuple:
    """(player, cycles): among usable players first..last, the one that reaches the predicted ball first
    (docs/players.md §4.3): the smallest i <= horizon for which some travel time to the ball after i cycles is
    <= i; ties go to the shorter travel time, then the lower index. (-1, horizon + 1) if nobody can.
    ``sums``: the players' ``decay_sums``."""
    horizon = int(cfg.intercept_horizon)
    for i in range(horizon + 1):
        bx, by = ball_in(bel, r, i, kp)
        best, best_c = -1, i + 1
        for j in range(first, last + 1):
            if j != bel.me[r] and bel.conf[r, j] < cfg.player_conf_threshold:
                continue
            c, _ = player_travel(bel, r, j, bx, by, i, False, sums, kp, cfg)
            if c < best_c:
                best, best_c = j, c
        if best >= 0:
            return best, i
    return -1, horizon + 1


@borrowing
def _line_circle(px: float, py: float, ux: float, uy: float, cx: float, cy: float, radius: float) -> tuple:
    """Parameters t1 <= t2 where the line p + t u meets the circle; (nan, nan) if it misses."""
    along = (cx - px) * ux + (cy - py) * uy
    perp2 = (cx - px) ** 2 + (cy - py) ** 2 - along**2
    if perp2 > radius**2:
        return math.nan, math.nan
    half = math.sqrt(radius**2 - perp2)
    return along - half, along + half


@borrowing
def collide_with_ball(bel: Belief, r: int, kp) -> tuple:
    """(ok, code, arg1): a command after which my body overlaps the ball next cycle (BasicPlayer::
    collideWithBall), the ball being near enough: a turn to my forward direction if I drift into it, else
    a dash at its next position."""
    me = bel.me[r]
    px, py, vx, vy = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1]
    body, effort = bel.body[r, me], bel.effort[r]
    ball_speed = math.hypot(bel.vel[r, 0, 0], bel.vel[r, 0, 1])
    if distance(px, py, bel.pos[r, 0, 0], bel.pos[r, 0, 1]) > ball_speed + kp.player_speed_max:
        return False, CMD_DASH, 0.0
    b1x, b1y = ball_in(bel, r, 1.0, kp)
    touch = kp.ball_size + kp.player_size
    fwd = math.radians(forward_angle(bel, r))
    _, moment, _ = turn_to_point(bel, r, px + math.cos(fwd), py + math.sin(fwd), 1.0, kp)
    sx, sy, _, _, _ = player_step(px, py, vx, vy, body, effort, CMD_TURN, moment, kp)
    if distance(sx, sy, b1x, b1y) < touch:
        return True, CMD_TURN, moment
    power = dash_power_for(b1x - px, b1y - py, body, vx, vy, effort, 1.0, kp)
    sx, sy, _, _, _ = player_step(px, py, vx, vy, body, effort, CMD_DASH, power, kp)
    if distance(sx, sy, b1x, b1y) < touch:
        return True, CMD_DASH, power
    return False, CMD_DASH, 0.0


@borrowing
def _opponent_within(bel: Belief, r: int, radius: float, cfg) -> bool:
    """Whether a usable opponent is within ``radius`` of me."""
    me = bel.me[r]
    first, last = opponents(bel, me)
    for j in range(first, last + 1):
        if bel.conf[r, j] >= cfg.player_conf_threshold and distance(
            bel.pos[r, j, 0], bel.pos[r, j, 1], bel.pos[r, me, 0], bel.pos[r, me, 1]
        ) < radius:
            return True
    return False


@borrowing
def close_intercept(bel: Belief, r: int, kp, cfg) -> tuple:
    """(ok, code, arg1): the close interception, as BasicPlayer::interceptClose does it (its doc comment
    describes turn+dash and dash+dash searches the code does not make; docs/design.md, "The players' skills").

    The one dash: to where my body line (from my position next cycle) meets the circle of radius
    player_size + ball_size + kickable_margin/6 around the next ball position, the meeting point further
    forward in my own frame first, then the other, then a dash at the ball; it counts if it ends within
    0.95 x kickable distance (the C++ predicts with the power cut to an integer). Then, with the ball
    within close range (3 player_speed_max + (1 + ball_decay) ball_speed_max + kickable distance):
    an opponent within 3 m and the dash -> dash. Else the candidates, in order: a turn towards my
    forward direction after which the ball stays within 0.8 x kickable distance next cycle (or after a
    second turn, two cycles on), taken if it leaves my body within 25 deg of forward; if my body is off
    forward by more than 25 deg, colliding with the ball (``collide_with_ball``), then a stopping dash
    that keeps the ball within 0.8 x kickable distance two cycles on; then the turn that keeps the ball
    however it leaves me; then the dash. With the ball beyond close range: turn to forward when it will be
    at my feet (0.7 x kickable distance, next cycle if I am off by 25 deg, else in two) with no opponent
    near, else collide if off forward, else the dash. (ok False: none applies.)"""
    me = bel.me[r]
    px, py, vx, vy = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1]
    body, effort = bel.body[r, me], bel.effort[r]
    speed = math.hypot(vx, vy)
    kickable = kickable_distance(kp)
    fwd = forward_angle(bel, r)
    sign = own_frame_sign(bel, r)
    close_range = (cfg.close_range_dash_cycles * kp.player_speed_max
                   + (1.0 + kp.ball_decay) * kp.ball_speed_max + kickable)
    in_range = distance(px, py, bel.pos[r, 0, 0], bel.pos[r, 0, 1]) <= close_range
    opp_close = _opponent_within(bel, r, cfg.close_opponent_radius, cfg)
    off_forward = abs(normalize_angle(fwd - body)) > cfg.close_heading_tolerance
    to_forward = turn_moment(normalize_angle(fwd - body), speed, kp)  # turnBodyToPoint(me + (1, fwd))
    collide_ok, collide_code, collide_a1 = False, CMD_DASH, 0.0  # only off forward is it ever used
    if off_forward:
        collide_ok, collide_code, collide_a1 = collide_with_ball(bel, r, kp)
    b1x, b1y = ball_in(bel, r, 1.0, kp)
    b2x, b2y = ball_in(bel, r, 2.0, kp)
    p1x, p1y = rolled_out(px, py, vx, vy, 1.0, kp.player_decay)
    p2x, p2y = rolled_out(px, py, vx, vy, 2.0, kp.player_decay)

    dash_ok, dash_power = False, 0.0
    ux, uy = math.cos(math.radians(body)), math.sin(math.radians(body))
    radius = kp.player_size + kp.ball_size + kp.kickable_margin * cfg.close_radius_margin
    t1, t2 = _line_circle(p1x, p1y, ux, uy, b1x, b1y, radius)
    if not math.isnan(t1):
        if sign * ux > 0.0 or (ux == 0.0 and sign * uy > 0.0):
            t1, t2 = t2, t1
        for t in (t1, t2):
            power = dash_power_for(p1x + t * ux - px, p1y + t * uy - py, body, vx, vy, effort, 1.0, kp)
            sx, sy, _, _, _ = player_step(px, py, vx, vy, body, effort, CMD_DASH, float(int(power)), kp)
            if distance(sx, sy, b1x, b1y) < cfg.close_margin * kickable:
                dash_ok, dash_power = True, power
                break
    if not dash_ok:
        power = dash_power_for(b1x - px, b1y - py, body, vx, vy, effort, 1.0, kp)
        sx, sy, _, _, _ = player_step(px, py, vx, vy, body, effort, CMD_DASH, power, kp)
        if distance(sx, sy, b1x, b1y) < cfg.close_margin * kickable:
            dash_ok, dash_power = True, power

    keep = cfg.close_turn_margin * kickable
    if in_range:
        if opp_close and dash_ok:
            return True, CMD_DASH, dash_power
        turn_ok = False
        sx, sy, svx, svy, sb = player_step(px, py, vx, vy, body, effort, CMD_TURN, to_forward, kp)
        if distance(sx, sy, b1x, b1y) < keep:
            turn_ok = True
            if abs(normalize_angle(fwd - sb)) < cfg.close_heading_tolerance:
                return True, CMD_TURN, to_forward
        second = turn_moment(normalize_angle(fwd - sb), math.hypot(svx, svy), kp)
        sx, sy, _, _, sb = player_step(sx, sy, svx, svy, sb, effort, CMD_TURN, second, kp)
        if distance(sx, sy, b2x, b2y) < keep:
            turn_ok = True
            if abs(normalize_angle(fwd - sb)) < cfg.close_heading_tolerance:
                return True, CMD_TURN, to_forward
        if off_forward and collide_ok:
            return True, collide_code, collide_a1
        if off_forward:
            stop = dash_power_for(0.0, 0.0, body, vx, vy, effort, 1.0, kp)
            sx, sy, _, _, _ = player_step(px, py, vx, vy, body, effort, CMD_DASH, stop, kp)
            if distance(sx, sy, b2x, b2y) < keep:
                return True, CMD_DASH, stop
        if turn_ok:
            return True, CMD_TURN, to_forward
        if dash_ok:
            return True, CMD_DASH, dash_power
        return False, CMD_DASH, 0.0
    near = cfg.close_near_margin * kickable
    if off_forward and not opp_close and distance(p1x, p1y, b1x, b1y) < near:
        return True, CMD_TURN, to_forward
    if not opp_close and distance(p2x, p2y, b2x, b2y) < near:
        return True, CMD_TURN, to_forward
    if off_forward and collide_ok:
        return True, collide_code, collide_a1
    if dash_ok:
        return True, CMD_DASH, dash_power
    return False, CMD_DASH, 0.0


UNKNOWN_FIRST = -1
"""``known_first`` of :func:`interception_point` and :func:`intercept` when my first reachable cycle is not
known. Passed, not a default: numba compiles a kernel again for an omitted argument, so the takers' calls
and the keepers', which pass a computed cycle, share one compiled ``intercept`` (docs/design.md, "One
version per type")."""


@borrowing
def interception_point(bel: Belief, r: int, mem: AgentMemory, sums, kp, cfg, known_first: int) -> tuple:
    """(i, x, y): the cycle and ball position at which I intercept (docs/players.md §5.2 step 2); (-1, the ball's
    position ``no_intercept_cycles`` ahead) if none within the horizon. First reachable i by default; the
    stability rule prefers a reachable i (at most 2 cycles after the first) whose ball position is within
    1 m of the point chosen last cycle, with margin and a ball still moving, if I intercepted during the
    last 2 cycles. The choice is remembered in ``mem``. (The framework scans on to first + 20 cycles, but
    only first..first + 2 can be chosen, so the scan stops there, and at the stable point once found; a
    point's distance after its moves is simulated only where the rule's other tests hold.)
    ``known_first`` >= 0: my first reachable cycle with the ball rolling is known (a keeper's
    ``fastest_to_ball`` found it), so the travel simulations before it are skipped, and at it too unless the
    stability rule needs my distance there; -1 (:data:`UNKNOWN_FIRST`): unknown."""
    me = bel.me[r]
    px, py, vx, vy = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1]
    fx, fy = final_position(px, py, vx, vy, kp.player_decay)
    kickable = kickable_distance(kp)
    ball_speed = math.hypot(bel.vel[r, 0, 0], bel.vel[r, 0, 1])
    recent = mem.intercept_time[r] >= 0 and bel.time[r] - mem.intercept_time[r] <= cfg.stability_window
    first, stable = -1, -1
    for i in range(int(cfg.intercept_horizon) + 1):
        if stable >= 0 or (first >= 0 and i > first + cfg.stability_window):
            break
        bx, by = ball_in(bel, r, i, kp)
        if abs(bx) > kp.pitch_length / 2.0 or abs(by) > kp.pitch_width / 2.0:
            break
        if i < known_first:
            continue
        reach = (i + kickable) * kp.player_speed_max
        if compared_hypot(bx - fx, by - fy, reach) / kp.player_speed_max > i + kickable:
            continue
        # the stability rule's tests that need no simulation: a point failing them can only be the first
        # (whether it is reached is all that matters then) and is not simulated at all once that is known
        candidate = (
            recent
            and compared_hypot(mem.intercept_point[r, 0] - bx, mem.intercept_point[r, 1] - by,
                               cfg.stability_radius) < cfg.stability_radius
            and ball_speed * kp.ball_decay**i > cfg.stability_ball_speed
        )
        if first >= 0 and not candidate:
            continue
        if i == known_first and not candidate:
            reached, end = i, math.nan
        else:
            reached, end = player_travel(bel, r, me, bx, by, i, candidate, sums, kp, cfg)
        if reached > i:
            continue
        if first < 0:
            first = i
            if not recent:
                break
        if candidate and end < cfg.stability_margin * kickable:
            stable = i
    chosen = stable if stable >= 0 else first
    if chosen < 0:
        x, y = ball_in(bel, r, cfg.no_intercept_cycles, kp)
        return -1, x, y
    x, y = ball_in(bel, r, chosen, kp)
    mem.intercept_point[r, 0] = x
    mem.intercept_point[r, 1] = y
    mem.intercept_time[r] = bel.time[r]
    return chosen, x, y


@borrowing
def intercept(bel: Belief, r: int, mem: AgentMemory, sums, kp, cfg, known_first: int) -> tuple:
    """Intercept / GoToBall (docs/players.md §5.2 step 3): the close intercept when the chosen point is < 3 cycles
    away and one exists; no move when my position rolled out min(i, 4) cycles is already within 0.5 m of
    the point (the framework then turns to its global 0 deg, ``forward_angle``, a quirk kept); else move
    to the point, sized to arrive in i cycles (``intercept_move``). With no reachable point, move towards
    the ball's position 100 cycles ahead, paced to arrive in 100 cycles, as the C++ code does
    (``predictCommandToInterceptBall``: iFirstBall stays 100; its doc comment says the ball's current
    position).
    ``known_first``: as in ``interception_point``."""
    me = bel.me[r]
    i, x, y = interception_point(bel, r, mem, sums, kp, cfg, known_first)
    if 0 <= i < cfg.close_max_cycle:
        ok, code, a1 = close_intercept(bel, r, kp, cfg)
        if ok:
            return _unstuck(bel, r, mem, code, a1, x, y, kp, cfg)
    px, py = bel.pos[r, me, 0], bel.pos[r, me, 1]
    cycles = cfg.no_intercept_cycles if i < 0 else float(i)
    roll = min(cycles, cfg.intercept_roll_cycles)
    fx, fy = rolled_out(px, py, bel.vel[r, me, 0], bel.vel[r, me, 1], roll, kp.player_decay)
    if distance(fx, fy, x, y) < cfg.intercept_stay_radius:
        fwd = math.radians(forward_angle(bel, r))
        return turn_to_point(bel, r, px + math.cos(fwd), py + math.sin(fwd), 1.0, kp)
    code, a1 = intercept_move(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1], bel.body[r, me],
        bel.effort[r], x, y, max(cycles, 1.0), kp, cfg,
    )
    return _unstuck(bel, r, mem, code, a1, x, y, kp, cfg)


@borrowing
def _unstuck(bel: Belief, r: int, mem: AgentMemory, code: int, a1: float, x: float, y: float, kp, cfg) -> tuple:
    """The intercept's command (code, a1), unless it is one backward dash too many: a player believes, as the
    C++ players do, that it can dash backwards, and rcssserver 17 on (min_dash_power 0) ignores such dashes;
    two takers doing so to a ball held behind them never get it (docs/design.md, "The players' skills"). So
    after ``stuck_dash_limit`` backward dashes sent standing still since it last moved, a player turns to
    the interception point (x, y) instead. Returns (code, arg1, arg2)."""
    me = bel.me[r]
    if math.hypot(bel.vel[r, me, 0], bel.vel[r, me, 1]) >= cfg.still_speed:
        mem.stuck_dashes[r] = 0
    elif code == CMD_DASH and a1 < 0.0:
        mem.stuck_dashes[r] += 1
        if mem.stuck_dashes[r] > cfg.stuck_dash_limit:
            mem.stuck_dashes[r] = 0
            return turn_to_point(bel, r, x, y, 1.0, kp)
    return code, a1, 0.0


__all__ = ["UNKNOWN_FIRST", "close_intercept", "collide_with_ball", "decay_sums", "fastest_to_ball", "intercept",
           "intercept_move", "interception_point", "player_travel", "travel"]
