"""The players' skills: intercept, HoldBall, kicks, PassBall, GoToPoint, ball search, travel time.

A re-creation of the UvA Trilearn / keepaway-framework skills as described in `keepaway-agents.md` 2
(section numbers below refer to it). Every skill is a numba kernel on one row ``r`` of a ``Belief``
and returns a command triple ``(code, arg1, arg2)`` with the CMD_* codes of `core/objects.py`
(dash: power; turn: moment; kick: power, direction relative to the body). The neck is chosen separately
(``neck_to_point``/``neck_with_body``) by the decision loops. Constants come from the server parameter
record ``kp`` and from ``AgentConfig.kernel()`` (``cfg``).
"""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, fields

import numpy as np
from keepaway.core.jit import borrowing, njit
from keepaway.core.records import kernel_record

from keepaway.agents.belief import AgentMemory, Belief
from keepaway.agents.geometry import (
    DECIDE_SLACK,
    ball_after_kick,
    compared_hypot,
    dash_power_along,
    dash_power_for,
    dash_velocity,
    direction,
    distance,
    final_position,
    geometric_sum,
    kick_rate,
    near,
    nearer_than,
    normalize_angle,
    player_step,
    rolled_out,
    turn_effect,
    turn_moment,
)
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_TURN
from keepaway.protocol.advice import GETOPEN_POLICY_NAMES, PASS_POLICY_NAMES

# Pass policies (spec `keepaway-task.md` 3); EXTERNAL: the caller's learner picks the action.
PASS_RANDOM = 0
PASS_HANDCODED = 1
PASS_EXTERNAL = 2
PASS_HOLD = 3
# GetOpen policies (spec `keepaway-task.md` 4; HANDCODED_CONE: the framework variant, agents.md 2.5).
GETOPEN_RANDOM = 0
GETOPEN_HANDCODED = 1
GETOPEN_HANDCODED_CONE = 2
GETOPEN_LEARNED = 3
GETOPEN_EXTERNAL = 4  # the caller picks the grid point (agents.player, outside decisions); no CLI name
# The policies' names on the command line, in configurations and in the coach's advice (declared with
# the advice, protocol.advice), shared by every mode, and their codes.
PASS_POLICIES = dict(zip(PASS_POLICY_NAMES, (PASS_RANDOM, PASS_HANDCODED, PASS_EXTERNAL, PASS_HOLD), strict=True))
GETOPEN_POLICIES = dict(zip(GETOPEN_POLICY_NAMES,
                            (GETOPEN_RANDOM, GETOPEN_HANDCODED, GETOPEN_HANDCODED_CONE, GETOPEN_LEARNED), strict=True))


@dataclass(frozen=True)
class AgentConfig:
    """The players' own constants (not the server's), each with the spec section it comes from."""

    pass_policy: int = PASS_HANDCODED  # keepaway-task.md 3
    getopen_policy: int = GETOPEN_HANDCODED  # keepaway-task.md 4
    ball_conf_threshold: float = 0.90  # agents.md 1: ball "known"
    player_conf_threshold: float = 0.88  # agents.md 1: player usable
    pass_end_speed: float = 1.2  # agents.md 2.3: PlayerSettings default
    hold_ratio_keeper: float = 0.7  # agents.md 2.2
    hold_ratio_taker: float = 0.3  # agents.md 2.2
    hold_opponent_radius: float = 5.0  # agents.md 2.2 step 1
    hold_escape_angle: float = 45.0  # agents.md 2.2 step 1
    hold_ball_tolerance: float = 0.3  # agents.md 2.2 step 2
    hold_turn_safety: float = 0.85  # agents.md 2.2 step 2 (x kickable distance)
    still_ball_speed: float = 0.1  # agents.md 2.2 step 3
    freeze_keep_ratio: float = 0.8  # agents.md 2.2 step 3 (x kickable distance)
    freeze_target_ratio: float = 0.7  # agents.md 2.2 step 3 (x kickable distance)
    freeze_inset: float = 0.1  # BasicPlayer::freezeBall, agents.md 2.2 step 3
    pitch_pullback: float = 0.2  # BasicPlayer::kickBallCloseToBody, agents.md 2.2 step 3
    pass_speed_ratio: float = 0.85  # BasicPlayer::kickTo, PlayerWhenToKick (x ball_accel_max)
    pass_kick_rate_ratio: float = 0.85  # agents.md 2.3 (x kick_power_rate)
    reposition_ratio: float = 0.16  # agents.md 2.3
    pass_power_ok: float = 105.0  # agents.md 2.3
    pass_power_pressed: float = 130.0  # agents.md 2.3
    pass_pressure_radius: float = 2.0  # agents.md 2.3
    turn_threshold: float = 7.0  # agents.md 2.4 (GetOpen's moveToPos angle)
    max_sim_turns: float = 5.0  # agents.md 2.4
    max_direct_turns: float = 2.0  # agents.md 2.4: 1-2 turns -> turn, 3+ -> brake
    turn_aim_cycles: float = 2.0  # agents.md 2.4: turn aimed at my position 2 cycles ahead
    intercept_horizon: float = 30.0  # agents.md 1 step 4, 2.1 step 2
    no_intercept_cycles: float = 100.0  # predictCommandToInterceptBall: no point reachable -> the ball 100 ahead
    intercept_roll_cycles: float = 4.0  # WorldModel::predictCommandTurnTowards: position min(i, 4) ahead
    intercept_back_distance: float = 2.5  # WorldModel::predictCommandToMoveToPos default dDistBack
    turn_ratio_near: float = 0.9  # WorldModel::predictCommandTurnTowards dRatioTurn (<= 10 m)
    turn_ratio_mid: float = 2.0  # same (10-20 m)
    turn_ratio_far: float = 3.0  # same (> 20 m)
    turn_mid_distance: float = 10.0  # same
    turn_far_distance: float = 20.0  # same
    close_radius_margin: float = 1.0 / 6.0  # agents.md 2.1 step 1 (x kickable_margin)
    close_margin: float = 0.95  # BasicPlayer::interceptClose: one dash succeeds (x kickable distance)
    close_turn_margin: float = 0.8  # same: a turn (or a stopping dash) keeps the ball (x kickable distance)
    close_near_margin: float = 0.7  # same, ball beyond close range: ball already at my feet (x kickable)
    close_heading_tolerance: float = 25.0  # same, angThreshold: body close enough to the desired heading
    close_opponent_radius: float = 3.0  # same, bOppClose: an opponent this near -> dash first
    close_range_dash_cycles: float = 3.0  # same: close range 3 player_speed_max + (1 + ball_decay)
    back_turn_margin: float = 0.9  # WorldModel::predictCommandTurnTowards: turn with the back (x kickable)
    back_turn_max_cycles: float = 4.0  # same: only when arriving in fewer cycles
    close_max_cycle: float = 3.0  # agents.md 2.1 step 3
    stability_radius: float = 1.0  # agents.md 2.1 step 2
    stability_margin: float = 0.7  # agents.md 2.1 step 2 (x kickable distance)
    stability_ball_speed: float = 0.6  # agents.md 2.1 step 2
    stability_window: float = 2.0  # agents.md 2.1 step 2 (cycles)
    intercept_stay_radius: float = 0.5  # agents.md 2.1 step 3
    # Not in the framework (a deviation, docs/design.md): a player that has sent this many backward dashes
    # while standing still, since it last moved, turns to its interception point instead of the next one.
    stuck_dash_limit: float = 30.0
    still_speed: float = 0.01  # standing still: sensed speed below this (m/cycle)
    search_turn: float = 60.0  # agents.md 1 step 2
    search_memory: float = 3.0  # BasicPlayer::searchBall: side kept for 3 cycles
    hc_hold_distance: float = 5.0  # keepaway-task.md 3, P:HC C1
    hc_angle_weight: float = 0.25  # keepaway-task.md 3, P:HC C2
    hc_pass_threshold: float = 22.5  # keepaway-task.md 3, P:HC C3
    go_safety_angle: float = 18.4  # keepaway-task.md 4, GO:HC
    go_cone_ratio: float = 0.3  # agents.md 2.5 step 4
    grid_points: float = 5.0  # agents.md 2.5 step 2 (per side)
    grid_margin: float = 0.15  # agents.md 2.5 step 2
    arrival_radius: float = 1.5  # agents.md 2.5 step 6, 2.6
    mark_distance: float = 4.0  # agents.md 3 step 3
    mark_cone_ratio: float = 0.3  # agents.md 3 step 3
    # Not in the spec (an option, off by default): GO:L's variables 9-10 measured from predictedBallPos
    # (as GO:HC's lane test) instead of from the keeper now closest to the ball (keepaway-task.md 4);
    # the measurements that kept the paper's definition are in docs/design.md.
    getopen_lane_from_predicted_ball: bool = False
    # Say and hear (agents/say.py; KeepawayPlayer::makeSayMessage, WorldModelSayMsgTypes.cc). Off: silent
    # players that hear nothing, to measure what talking changes.
    say_messages: bool = True
    say_ball_range: float = 20.0  # makeSayMessage: a ball seen with its change pair within this is said
    say_pass_margin: float = 0.2  # same: a kick taking the ball this far beyond kickable distance is a pass
    hear_ball_near: float = 3.0  # WMBallInfo::process: a heard ball is not taken this close to me
    hear_ball_stale_cycles: float = 3.0  # same: a ball whose change pair is older than this is replaced
    hear_velocity_gap: float = 0.3  # same, and processPerfectHearInfoBall: a velocity this different

    def kernel(self) -> np.record:
        """The fields (:data:`AgentKernel`) as a record of floats, the form numba kernels take
        (``core.records``)."""
        return kernel_record(AgentKernel(*(float(getattr(self, n)) for n in AgentKernel._fields)))


AgentKernel = namedtuple("AgentKernel", [f.name for f in fields(AgentConfig)])
AgentKernel.__module__ = __name__


@borrowing
def kickable_distance(kp) -> float:
    """player_size + kickable_margin + ball_size = 1.085 m (spec header)."""
    return kp.player_size + kp.kickable_margin + kp.ball_size


@borrowing
def ball_in(bel: Belief, r: int, n: float, kp) -> tuple:
    """The believed ball position after ``n`` cycles (spec 2, shared geometry)."""
    return rolled_out(
        bel.pos[r, 0, 0], bel.pos[r, 0, 1], bel.vel[r, 0, 0], bel.vel[r, 0, 1], n, kp.ball_decay
    )


@borrowing
def ball_kickable(bel: Belief, r: int, obj: int, kp) -> bool:
    """Whether player ``obj`` can kick the ball (centre distance < kickable distance, spec 1 step 3)."""
    kickable = kickable_distance(kp)
    return compared_hypot(bel.pos[r, 0, 0] - bel.pos[r, obj, 0], bel.pos[r, 0, 1] - bel.pos[r, obj, 1],
                          kickable) < kickable


@borrowing
def closest_to_ball(bel: Belief, r: int, first: int, last: int, skip: int, cfg) -> int:
    """The usable player (conf >= threshold, not ``skip``) among objects first..last closest to the ball,
    -1 if none; ties go to the lower index."""
    best = -1
    best_d = math.inf
    for j in range(first, last + 1):
        if j == skip or (j != bel.me[r] and bel.conf[r, j] < cfg.player_conf_threshold):
            continue
        d = nearer_than(bel.pos[r, 0, 0] - bel.pos[r, j, 0], bel.pos[r, 0, 1] - bel.pos[r, j, 1], best_d)
        if d < best_d:
            best, best_d = j, d
    return best


@borrowing
def distances_from(bel: Belief, r: int, ox: float, oy: float, last: int, skip: int, out) -> None:
    """``out[j]`` = distance((ox, oy), object j) for the players j = 1..last except ``skip``."""
    for j in range(1, last + 1):
        if j != skip:
            out[j] = distance(ox, oy, bel.pos[r, j, 0], bel.pos[r, j, 1])


@borrowing
def sort_by_distance(dist, first: int, last: int, skip: int, out) -> int:
    """Write the objects first..last except ``skip`` into ``out`` by increasing ``dist[j]`` (their
    :func:`distances_from` a point; stable: lower index first on ties); returns how many were written."""
    n = 0
    for j in range(first, last + 1):
        if j == skip:
            continue
        d = dist[j]
        k = n
        while k > 0 and dist[out[k - 1]] > d:
            out[k] = out[k - 1]
            k -= 1
        out[k] = j
        n += 1
    return n


@borrowing
def opponent_range(obj: int, n_keepers: int, n_players: int) -> tuple:
    """Object index range (first, last), inclusive, of the opponents of player ``obj`` among objects
    1..n_players (keepers first): the takers for a keeper, the keepers for a taker."""
    if 1 <= obj <= n_keepers:
        return n_keepers + 1, n_players
    return 1, n_keepers


@borrowing
def opponents(bel: Belief, obj: int) -> tuple:
    """Object index range (first, last) of the opponents of player ``obj``."""
    return opponent_range(obj, bel.n_keepers, bel.n_keepers + bel.n_takers)


@borrowing
def frame_sign(obj: int, n_keepers: int) -> float:
    """+1 if player ``obj``'s own frame is the server's (a keeper), -1 if it is mirrored (a taker):
    :func:`own_frame_sign` on an object index."""
    return 1.0 if 1 <= obj <= n_keepers else -1.0


@borrowing
def own_frame_sign(bel: Belief, r: int) -> float:
    """+1 if my own frame is the server's, -1 if it is mirrored. The C++ players mirror the field for the
    right-hand team, the takers (rcssserver keepaway mode: keepers left), so where their code says
    "global 0", "forward in x" or "the opponent goal" a taker means the server's 180 deg, -x and the
    left goal."""
    return frame_sign(bel.me[r], bel.n_keepers)


@borrowing
def forward_angle(bel: Belief, r: int) -> float:
    """The server-frame direction that my own frame calls 0 deg (``own_frame_sign``)."""
    return 0.0 if own_frame_sign(bel, r) > 0.0 else 180.0


# ----------------------------------------------------------------------------------------------- neck


@borrowing
def neck_to_point(bel: Belief, r: int, cmd: int, a1: float, tx: float, ty: float, kp) -> float:
    """turn_neck moment that points the head at (tx, ty) after this cycle's main command, the neck
    clipped to its range (BasicPlayer::turnNeckToPoint)."""
    me = bel.me[r]
    px, py, _, _, body = player_step(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1], bel.body[r, me],
        bel.effort[r], cmd, a1, kp,
    )
    want = normalize_angle(direction(tx - px, ty - py) - body)
    want = min(kp.max_neck_angle, max(kp.min_neck_angle, want))
    return want - bel.neck[r, me]


@borrowing
def neck_to_ball(bel: Belief, r: int, cmd: int, a1: float, kp) -> float:
    """turn_neck moment towards the believed ball position."""
    return neck_to_point(bel, r, cmd, a1, bel.pos[r, 0, 0], bel.pos[r, 0, 1], kp)


@borrowing
def neck_with_body(bel: Belief, r: int) -> float:
    """turn_neck moment that aligns the neck with the body (spec 1 step 2)."""
    return -bel.neck[r, bel.me[r]]


@borrowing
def write_action(
    r: int, code: int, a1: float, a2: float, neck: float, out_main, out_a1, out_a2, out_neck
) -> None:
    """Store one decision (main command and neck moment) in row ``r`` of the caller's arrays."""
    out_main[r] = code
    out_a1[r] = a1
    out_a2[r] = a2
    out_neck[r] = neck


# ------------------------------------------------------------------------------------------ movement


@borrowing
def turn_to_point(bel: Belief, r: int, tx: float, ty: float, cycles: float, kp) -> tuple:
    """Turn the body towards (tx, ty) as seen from my position ``cycles`` ahead, compensating inertia
    (BasicPlayer::turnBodyToPoint, spec 2 turn inertia)."""
    me = bel.me[r]
    vx, vy = bel.vel[r, me, 0], bel.vel[r, me, 1]
    px, py = rolled_out(bel.pos[r, me, 0], bel.pos[r, me, 1], vx, vy, cycles, kp.player_decay)
    angle = normalize_angle(direction(tx - px, ty - py) - bel.body[r, me])
    return CMD_TURN, turn_moment(angle, math.hypot(vx, vy), kp), 0.0


@borrowing
def move_command(
    px: float, py: float, vx: float, vy: float, body: float, effort: float,
    tx: float, ty: float, cycles: float, kp, cfg,
) -> tuple:
    """GoToPoint for any player state (spec 2.4): from the rolled-out reference position dash if the
    target is within the 7 deg threshold of the body direction, else count the turns needed (up to 5):
    1-2 -> turn (aimed from my position 2 cycles ahead), 3+ -> brake with a dash to stand still.
    Dash power covers the forward distance in ``cycles`` cycles. Returns (code, arg1)."""
    fx, fy = final_position(px, py, vx, vy, kp.player_decay)
    goal_dir = direction(tx - fx, ty - fy)
    angle = normalize_angle(goal_dir - body)
    if abs(angle) <= cfg.turn_threshold:
        return CMD_DASH, dash_power_for(tx - px, ty - py, body, vx, vy, effort, cycles, kp)
    sx, sy, svx, svy, sb = px, py, vx, vy, body
    turns = 0
    while abs(angle) > cfg.turn_threshold and turns < cfg.max_sim_turns:
        turns += 1
        sx, sy, svx, svy, sb = player_step(
            sx, sy, svx, svy, sb, effort, CMD_TURN, turn_moment(angle, math.hypot(svx, svy), kp), kp
        )
        angle = normalize_angle(goal_dir - sb)
    if turns <= cfg.max_direct_turns:
        ax, ay = rolled_out(px, py, vx, vy, cfg.turn_aim_cycles, kp.player_decay)
        aim = normalize_angle(direction(tx - ax, ty - ay) - body)
        return CMD_TURN, turn_moment(aim, math.hypot(vx, vy), kp)
    return CMD_DASH, dash_power_for(0.0, 0.0, body, vx, vy, effort, 1.0, kp)


@borrowing
def go_to_point(bel: Belief, r: int, tx: float, ty: float, kp, cfg) -> tuple:
    """GoToPoint(target, 7 deg) for row ``r`` (spec 2.4)."""
    me = bel.me[r]
    code, a1 = move_command(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1], bel.body[r, me],
        bel.effort[r], tx, ty, 1.0, kp, cfg,
    )
    return code, a1, 0.0


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
    """One move towards an interception point to be reached in ``cycles`` cycles, as the framework's
    intercept and travel-time code moves (WorldModel::predictCommandToMoveToPos with back distance 2.5;
    spec 2.1 steps 2-3 name the GoToPoint rule, the code uses this one): from my position rolled out
    min(cycles, 4) cycles, turn towards the point only if it lies more than ratio x kickable distance
    off my body line (ratio 0.9 within 10 m, 2 within 20 m, 3 beyond) or behind me beyond 2.5 m, or turn
    my back to a close point (``_intercept_turns``); else dash (backwards if it is behind) with the power
    that covers the distance in ``cycles``. (The code's angle threshold never applies there: an
    operator-precedence slip makes it 180.) Returns (code, arg1)."""
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
    """Simulate ``n`` intercept moves towards (tx, ty), paced to arrive after n cycles (spec 1 step 4,
    2.1 step 2). Returns (first cycle at which the player is within ``radius``, or n + 1; distance after
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
    (spec 1 step 4): the smallest i <= horizon for which some travel time to the ball after i cycles is
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
def search_ball(bel: Belief, r: int, mem: AgentMemory, kp, cfg) -> tuple:
    """Turn 60 deg towards the side where the ball was last seen; the side is re-chosen only after
    3 cycles without searching (spec 1 step 2, BasicPlayer::searchBall)."""
    me = bel.me[r]
    now = bel.time[r]
    px, py, body = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.body[r, me]
    if mem.search_time[r] < 0 or now - mem.search_time[r] > cfg.search_memory:
        rel = normalize_angle(direction(bel.pos[r, 0, 0] - px, bel.pos[r, 0, 1] - py) - body)
        mem.search_sign[r] = 1.0 if rel >= 0.0 else -1.0
    mem.search_time[r] = now
    aim = math.radians(body + cfg.search_turn * mem.search_sign[r])
    return turn_to_point(bel, r, px + math.cos(aim), py + math.sin(aim), 1.0, kp)


# ------------------------------------------------------------------------------------------- kicking


@borrowing
def _my_kick_rate(bel: Belief, r: int, kp) -> float:
    me = bel.me[r]
    return kick_rate(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.body[r, me], bel.pos[r, 0, 0], bel.pos[r, 0, 1], kp
    )


@borrowing
def _power_for_speed(speed: float, rate: float) -> float:
    """Kick power giving a velocity change ``speed`` at effective ``rate`` (spec 2, shared geometry)."""
    return speed / rate if rate > 0.0 else math.inf


@borrowing
def accelerate_ball_to(bel: Belief, r: int, wx: float, wy: float, kp) -> tuple:
    """Kick that gives the ball velocity (wx, wy); if one kick cannot, a full-power kick that aligns the
    ball's new velocity with it (BasicPlayer::accelerateBallToVelocity, spec 2.3)."""
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
    my next position, kick it towards a point inside 0.7 x kickable distance instead (spec 2.2 step 3)."""
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
    moving ball, kick at full power if the ball is still (spec 2.2 step 3)."""
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
    """HoldBall (spec 2.2): keep the ball ``ratio`` x kickable_margin from the body, away from the
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
    # The framework tests the relative angle as if it were global (a quirk kept, spec 2.2 step 2).
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
    n = round(log(dist (1/d - 1)/end + 1) / log(1/d)), v0 = end (1/d)^n (spec 2.3)."""
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
    """kickTo(target, end speed) (spec 2.3): the initial speed that makes the ball arrive at ``end_speed``;
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
    """PassBall-k (spec 1 step 3d, 2.3): kickTo the k-th nearest keeper from me (k = 1 nearest teammate),
    resolved from the current positions, at the pass end speed."""
    me = bel.me[r]
    order = np.empty(bel.n_keepers, dtype=np.int64)
    dist = np.empty(bel.n_keepers + 1)
    distances_from(bel, r, bel.pos[r, me, 0], bel.pos[r, me, 1], bel.n_keepers, me, dist)
    sort_by_distance(dist, 1, bel.n_keepers, me, order)
    target = order[k - 1]
    return kick_to(bel, r, bel.pos[r, target, 0], bel.pos[r, target, 1], cfg.pass_end_speed, kp, cfg)


# ----------------------------------------------------------------------------------------- intercept


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
    """(ok, code, arg1): the close interception, as BasicPlayer::interceptClose does it (its doc comment,
    which spec 2.1 step 1 follows, describes turn+dash and dash+dash searches the code does not make).

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
    """(i, x, y): the cycle and ball position at which I intercept (spec 2.1 step 2); (-1, the ball's
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
    """Intercept / GoToBall (spec 2.1 step 3): the close intercept when the chosen point is < 3 cycles
    away and one exists; no move when my position rolled out min(i, 4) cycles is already within 0.5 m of
    the point (the framework then turns to its global 0 deg, ``forward_angle``, a quirk kept); else move
    to the point, sized to arrive in i cycles (``intercept_move``). With no reachable point, move towards
    the ball's position 100 cycles ahead, paced to arrive in 100 cycles, as the C++ code does
    (``predictCommandToInterceptBall``: iFirstBall stays 100; the spec's comment says the ball's current
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
    """The intercept's command (code, a1), unless it is one backward dash too many: a player believes,
    as the C++ players do, that it can dash backwards, and rcssserver 17 on (min_dash_power 0) ignores
    such dashes; two takers doing so to a ball held behind them never get it (docs/design.md). So after
    ``stuck_dash_limit`` backward dashes sent standing still since it last moved, a player turns to the
    interception point (x, y) instead. Returns (code, arg1, arg2)."""
    me = bel.me[r]
    if math.hypot(bel.vel[r, me, 0], bel.vel[r, me, 1]) >= cfg.still_speed:
        mem.stuck_dashes[r] = 0
    elif code == CMD_DASH and a1 < 0.0:
        mem.stuck_dashes[r] += 1
        if mem.stuck_dashes[r] > cfg.stuck_dash_limit:
            mem.stuck_dashes[r] = 0
            return turn_to_point(bel, r, x, y, 1.0, kp)
    return code, a1, 0.0
