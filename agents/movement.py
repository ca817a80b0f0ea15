"""The players' moves: the neck's turn, turning towards a point, GoToPoint and the ball search.

Skills of the UvA Trilearn / keepaway-framework players (docs/players.md §5; keepaway-0.6
player/BasicPlayer.cc). Every skill here and in `agents/interception.py` and `agents/kicks.py` is a numba
kernel on one row ``r`` of a ``Belief`` and returns a command triple ``(code, arg1, arg2)`` with the CMD_*
codes of `core/objects.py` (dash: power; turn: moment; kick: power, direction relative to the body). The neck
is chosen separately (``neck_to_point``/``neck_with_body``) by the decision loops. Constants come from the
server parameter record ``kp`` and from ``AgentConfig.kernel()`` (``cfg``).
"""

from __future__ import annotations

import math

from keepaway.agents.belief import AgentMemory, Belief
from keepaway.agents.geometry import (
    dash_power_for,
    direction,
    final_position,
    normalize_angle,
    player_step,
    rolled_out,
    turn_moment,
)
from keepaway.core.jit import borrowing
from keepaway.core.objects import CMD_DASH, CMD_TURN


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
    """turn_neck moment that aligns the neck with the body (docs/players.md §5.6)."""
    return -bel.neck[r, bel.me[r]]


@borrowing
def turn_to_point(bel: Belief, r: int, tx: float, ty: float, cycles: float, kp) -> tuple:
    """Turn the body towards (tx, ty) as seen from my position ``cycles`` ahead, compensating inertia
    (BasicPlayer::turnBodyToPoint; turn inertia, docs/players.md §5.1)."""
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
    """GoToPoint for any player state (docs/players.md §5.5): from the rolled-out reference position dash if the
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
    """GoToPoint(target, 7 deg) for row ``r`` (docs/players.md §5.5)."""
    me = bel.me[r]
    code, a1 = move_command(
        bel.pos[r, me, 0], bel.pos[r, me, 1], bel.vel[r, me, 0], bel.vel[r, me, 1], bel.body[r, me],
        bel.effort[r], tx, ty, 1.0, kp, cfg,
    )
    return code, a1, 0.0


@borrowing
def search_ball(bel: Belief, r: int, mem: AgentMemory, kp, cfg) -> tuple:
    """Turn 60 deg towards the side where the ball was last seen; the side is re-chosen only after
    3 cycles without searching (docs/players.md §5.6, BasicPlayer::searchBall)."""
    me = bel.me[r]
    now = bel.time[r]
    px, py, body = bel.pos[r, me, 0], bel.pos[r, me, 1], bel.body[r, me]
    if mem.search_time[r] < 0 or now - mem.search_time[r] > cfg.search_memory:
        rel = normalize_angle(direction(bel.pos[r, 0, 0] - px, bel.pos[r, 0, 1] - py) - body)
        mem.search_sign[r] = 1.0 if rel >= 0.0 else -1.0
    mem.search_time[r] = now
    aim = math.radians(body + cfg.search_turn * mem.search_sign[r])
    return turn_to_point(bel, r, px + math.cos(aim), py + math.sin(aim), 1.0, kp)


__all__ = ["go_to_point", "move_command", "neck_to_ball", "neck_to_point", "neck_with_body", "search_ball",
           "turn_to_point"]
